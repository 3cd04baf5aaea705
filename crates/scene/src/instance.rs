//! Instancing: the placement transform, placements read from a CSV file,
//! and the size budget every expansion is checked against before anything
//! is allocated.

use std::path::{Path, PathBuf};

use glam::DVec3;

use crate::Facet;

/// Most facets a scene may hold after instances are expanded.
pub const MAX_FACETS: usize = 20_000_000;
/// Most placements one object or point source may have.
pub const MAX_INSTANCES: usize = 1_000_000;
/// Most point sources a scene may hold after instances are expanded.
pub const MAX_POINT_SOURCES: usize = 1_000_000;
/// Most placed facets the shared objects of a scene may hold together:
/// the tracer names every facet by a `u32`, `u32::MAX` meaning none.
pub const MAX_SHARED_FACETS: u64 = 4_000_000_000;
/// `instancing = "auto"` keeps an instanced object's placements as one
/// shared prototype when they would add more facets than this (and its
/// material does not emit): below it, copies keep the radiosity cache,
/// which needs a facet of its own per placement.
pub const SHARE_ABOVE_FACETS: usize = 1_000_000;

/// How an instanced object's placements are built (`instancing = …`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Instancing {
    /// Shared above [`SHARE_ABOVE_FACETS`] placed facets, else copied.
    Auto,
    /// A copy of the prototype's facets per placement.
    Expand,
    /// One prototype, traced under each placement's transform.
    Shared,
}

impl std::str::FromStr for Instancing {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Self::Auto),
            "expand" => Ok(Self::Expand),
            "shared" => Ok(Self::Shared),
            other => Err(format!(
                "unknown instancing '{other}': use \"auto\", \"expand\" or \"shared\""
            )),
        }
    }
}

/// An instanced object kept as one prototype and its placements (pbrt-v4's
/// object instances): the tracer builds one BVH over the prototype and a
/// top-level one over the placements, so a placement costs a transform.
/// Its material does not emit (each placement of an emitter is a light of
/// its own, and is expanded).
#[derive(Clone, Debug)]
pub struct SharedInstances {
    /// Index into [`crate::Scene::objects`].
    pub object: usize,
    /// The object's facets once, its own transform applied.
    pub prototype: Vec<Facet>,
    /// Each placement's map from the prototype's frame to the scene's.
    pub placements: Vec<glam::DAffine3>,
}

impl SharedInstances {
    /// Facets it places: the prototype's, once per placement.
    pub fn placed_facets(&self) -> u64 {
        self.prototype.len() as u64 * self.placements.len() as u64
    }

    /// The prototype's bounding box, lower and upper corners.
    pub fn prototype_bounds(&self) -> (DVec3, DVec3) {
        bounds(&self.prototype)
    }

    /// The corners of the prototype's box under every placement (they
    /// bound every placed vertex): 8 per placement.
    pub fn placed_corners(&self) -> impl Iterator<Item = DVec3> + '_ {
        let corners = box_corners(self.prototype_bounds());
        self.placements
            .iter()
            .flat_map(move |a| corners.map(|c| a.transform_point3(c)))
    }
}

/// The bounding box of `facets`' vertices, lower and upper corners.
pub(crate) fn bounds(facets: &[Facet]) -> (DVec3, DVec3) {
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for v in facets.iter().flat_map(|f| &f.vertices) {
        lo = lo.min(*v);
        hi = hi.max(*v);
    }
    (lo, hi)
}

/// The 8 corners of the box `lo..hi` (the tracer boxes its placements
/// with it too).
pub fn box_corners((lo, hi): (DVec3, DVec3)) -> [DVec3; 8] {
    std::array::from_fn(|k| {
        DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// `p ↦ R_z(θ)·(p ∘ scale) + translate`: scale (per axis), then rotate
/// counter-clockwise about +z (seen from above), then translate. The same
/// form serves an object's own `scale`/`rotate_z_deg`/`translate` and each
/// of its placements.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Xform {
    scale: DVec3,
    cos: f64,
    sin: f64,
    translate: DVec3,
}

impl Xform {
    /// `scale` positive and finite, `rotate_z_deg` finite and within
    /// ±[`MAX_ROTATION_DEG`] (checked by the callers). Multiples of 90° rotate exactly, so a grid of instances
    /// stays on its grid.
    pub(crate) fn new(scale: DVec3, rotate_z_deg: f64, translate: DVec3) -> Self {
        let r = rotate_z_deg.rem_euclid(360.0);
        let (sin, cos) = if r == 0.0 {
            (0.0, 1.0)
        } else if r == 90.0 {
            (1.0, 0.0)
        } else if r == 180.0 {
            (0.0, -1.0)
        } else if r == 270.0 {
            (-1.0, 0.0)
        } else {
            r.to_radians().sin_cos()
        };
        Xform {
            scale,
            cos,
            sin,
            translate,
        }
    }

    fn rotate(&self, v: DVec3) -> DVec3 {
        DVec3::new(
            self.cos * v.x - self.sin * v.y,
            self.sin * v.x + self.cos * v.y,
            v.z,
        )
    }

    /// A point.
    pub(crate) fn point(&self, p: DVec3) -> DVec3 {
        self.rotate(p * self.scale) + self.translate
    }

    /// A direction attached to the geometry (a point source's aim): scaled
    /// and rotated like the geometry, not translated; not normalised.
    pub(crate) fn direction(&self, d: DVec3) -> DVec3 {
        self.rotate(d * self.scale)
    }

    /// A placed facet's normal carried back into the prototype's frame:
    /// `Mᵀ n` for the linear part `M = R_z(θ)·diag(scale)` (normals map
    /// by `M⁻ᵀ`, so this undoes it up to length); not normalised.
    pub(crate) fn normal_back(&self, n: DVec3) -> DVec3 {
        let r = DVec3::new(
            self.cos * n.x + self.sin * n.y,
            -self.sin * n.x + self.cos * n.y,
            n.z,
        );
        r * self.scale
    }

    /// The same map as an affine transform (columns of `R_z(θ)·diag(scale)`).
    pub(crate) fn affine(&self) -> glam::DAffine3 {
        glam::DAffine3::from_mat3_translation(
            glam::DMat3::from_cols(
                self.rotate(DVec3::X * self.scale.x),
                self.rotate(DVec3::Y * self.scale.y),
                self.rotate(DVec3::Z * self.scale.z),
            ),
            self.translate,
        )
    }

    /// The smallest scale factor's magnitude.
    pub(crate) fn min_scale(&self) -> f64 {
        self.scale.abs().min_element()
    }

    /// True when a scale factor is outside 1e-6..=1e6: areas (squares of
    /// lengths) of a prototype's facets may then vanish or overflow.
    pub(crate) fn scale_is_extreme(&self) -> bool {
        self.scale
            .to_array()
            .iter()
            .any(|s| !(1e-6..=1e6).contains(s))
    }

    /// True when the transform preserves shape (uniform scale): a valid
    /// facet stays valid, so the per-facet checks need not be repeated.
    pub(crate) fn is_similarity(&self) -> bool {
        self.scale.x == self.scale.y && self.scale.y == self.scale.z
    }
}

/// One placement and where it was written, for errors.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Placement {
    pub(crate) xform: Xform,
    /// The entry's index in `instances = […]`, or its 1-based line in the
    /// `instances_csv` file.
    pub(crate) at: usize,
}

/// The header a placements CSV may start with.
pub const PLACEMENTS_CSV_HEADER: &str = "x,y,z,rotate_z_deg,scale";

/// The largest |rotation| about z, in degrees, a scene may give
/// (`rotate_z_deg` of an object, a placement or a moving body's key):
/// 2 777 turns, far more than any pose needs, while the angle still keeps
/// 1e-10 degree of precision once reduced to one turn. At 1e300 no bit of
/// the turn is left and the pose would be arbitrary.
pub const MAX_ROTATION_DEG: f64 = 1e6;

/// Whether `deg` is a rotation a scene may give: finite, within
/// ±[`MAX_ROTATION_DEG`].
pub(crate) fn rotation_ok(deg: f64) -> bool {
    deg.is_finite() && deg.abs() <= MAX_ROTATION_DEG
}

/// Why a placements CSV was refused; names the file and, for a row, its
/// 1-based line.
#[derive(Debug, thiserror::Error)]
pub(crate) enum PlacementsError {
    #[error("{}: cannot read: {source}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}:{line}: {problem}", path.display())]
    Row {
        path: PathBuf,
        line: usize,
        problem: RowError,
    },
    #[error("{}: no placements (the file is empty or holds only comments and a header)", path.display())]
    Empty { path: PathBuf },
}

/// What is wrong with one placements row.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum RowError {
    #[error(
        "expected five numbers '{PLACEMENTS_CSV_HEADER}'{}, found '{text}'",
        if *.after_header { "" } else { " (or that header)" }
    )]
    NotNumbers { text: String, after_header: bool },
    #[error("expected 5 columns ({PLACEMENTS_CSV_HEADER}), found {found}")]
    Columns { found: usize },
    #[error(
        "column {column} is empty (a doubled or trailing separator?): expected 5 columns ({PLACEMENTS_CSV_HEADER}), found {found}"
    )]
    EmptyColumn { column: usize, found: usize },
    #[error(
        "{axis} = {value} must be a finite number with |{axis}| ≤ {max_coordinate:e} scene units"
    )]
    Coordinate {
        axis: &'static str,
        value: f64,
        max_coordinate: f64,
    },
    #[error(
        "rotate_z_deg = {} must be a finite number with |rotate_z_deg| ≤ {MAX_ROTATION_DEG:e} degrees",
        crate::build::num(*.value)
    )]
    Rotation { value: f64 },
    #[error("scale = {} must be finite and > 0", crate::build::num(*.value))]
    Scale { value: f64 },
    #[error("more than {max} placements (the limit per object or point source)")]
    TooMany { max: usize },
}

/// Reads a placements CSV (`x,y,z,rotate_z_deg,scale` rows) through the
/// bounded reader spectra use.
pub(crate) fn read_placements_csv(
    path: &Path,
    max_coordinate: f64,
    reads: &gloam_io::ReadLog,
) -> Result<Vec<Placement>, PlacementsError> {
    let text =
        gloam_io::read_text(path, gloam_io::MAX_TEXT_FILE_BYTES, reads).map_err(|source| {
            PlacementsError::Read {
                path: path.to_path_buf(),
                source,
            }
        })?;
    parse_placements_csv(&text, path, max_coordinate, MAX_INSTANCES)
}

/// Parses placements CSV text (`path` labels errors), refusing more than
/// `max_placements` rows at the first row over.
pub(crate) fn parse_placements_csv(
    text: &str,
    path: &Path,
    max_coordinate: f64,
    max_placements: usize,
) -> Result<Vec<Placement>, PlacementsError> {
    let err = |line: usize, problem: RowError| PlacementsError::Row {
        path: path.to_path_buf(),
        line,
        problem,
    };
    let mut out = Vec::new();
    let mut seen_row = false;
    for (line_no, line, fields) in gloam_spectra::data_rows(text) {
        if let (Some(column), found) = empty_column(line) {
            return Err(err(line_no, RowError::EmptyColumn { column, found }));
        }
        let parsed: Option<Vec<f64>> = fields.iter().map(|f| f.parse().ok()).collect();
        let Some(nums) = parsed else {
            if !seen_row && fields.join(",").eq_ignore_ascii_case(PLACEMENTS_CSV_HEADER) {
                seen_row = true;
                continue;
            }
            return Err(err(
                line_no,
                RowError::NotNumbers {
                    text: gloam_io::shown(line).into_owned(),
                    after_header: seen_row,
                },
            ));
        };
        seen_row = true;
        let &[x, y, z, rot, s] = nums.as_slice() else {
            return Err(err(line_no, RowError::Columns { found: nums.len() }));
        };
        for (axis, value) in [("x", x), ("y", y), ("z", z)] {
            if !(value.is_finite() && value.abs() <= max_coordinate) {
                return Err(err(
                    line_no,
                    RowError::Coordinate {
                        axis,
                        value,
                        max_coordinate,
                    },
                ));
            }
        }
        if !rotation_ok(rot) {
            return Err(err(line_no, RowError::Rotation { value: rot }));
        }
        if !(s.is_finite() && s > 0.0) {
            return Err(err(line_no, RowError::Scale { value: s }));
        }
        if out.len() == max_placements {
            return Err(err(
                line_no,
                RowError::TooMany {
                    max: max_placements,
                },
            ));
        }
        out.push(Placement {
            xform: Xform::new(DVec3::splat(s), rot, DVec3::new(x, y, z)),
            at: line_no,
        });
    }
    if out.is_empty() {
        return Err(PlacementsError::Empty {
            path: path.to_path_buf(),
        });
    }
    Ok(out)
}

/// A row's first empty column (1-based) and its column count, empty ones
/// included. A comma or semicolon ends a column, so two with only spaces
/// between (or one at either end of the row) leave an empty one; runs of
/// spaces and tabs separate columns without making empty ones.
fn empty_column(line: &str) -> (Option<usize>, usize) {
    let mut first_empty = None;
    let mut count = 0usize;
    for piece in line.split([',', ';']) {
        let n = piece.split_whitespace().count();
        if n == 0 {
            first_empty.get_or_insert(count + 1);
        }
        count += n.max(1);
    }
    (first_empty, count)
}

/// glibc's chunk size for a heap allocation of `n` bytes (an estimate for
/// other allocators): what every memory estimate in gloam (a scene's
/// facets, a render's pixels) counts per block.
pub fn heap_chunk(n: usize) -> usize {
    if n == 0 {
        0
    } else {
        ((n + 8 + 15) & !15).max(32)
    }
}

/// Estimated bytes one facet of object `name` costs while the scene is
/// built: the `Facet` twice (the scene's list grows by doubling, and an
/// instanced object holds its prototype too), its vertex list (a quad, at
/// most) and its copy of the object's name. 256 for a name of up to 24
/// bytes, as documented in `docs/scene-format.md`.
pub(crate) fn facet_bytes(name: &str) -> usize {
    2 * std::mem::size_of::<Facet>()
        + heap_chunk(4 * std::mem::size_of::<DVec3>())
        + heap_chunk(name.len())
}

/// Bytes of memory this process may still allocate: the smallest of
/// `MemAvailable` (`/proc/meminfo`), the room left under a cgroup v2
/// memory limit, and the room left under `RLIMIT_AS` (`ulimit -v`, see
/// [`address_space_room`]: an allocation past it aborts — an 8192² render
/// under a 1.5 GB limit died in 0.8 s). `None` where
/// none can be read (not Linux). Every size check in gloam (scene
/// expansion, render, capture, bench) asks this.
pub fn available_memory_bytes() -> Option<u64> {
    available_memory().map(|(b, _)| b)
}

/// [`available_memory_bytes`] and what sets it, for messages:
/// `"MemAvailable"`, `"the cgroup's memory.max"` or `"RLIMIT_AS (ulimit -v)"`.
pub fn available_memory() -> Option<(u64, &'static str)> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok().and_then(|s| {
        let kb: u64 = s
            .lines()
            .find(|l| l.starts_with("MemAvailable:"))?
            .split_whitespace()
            .nth(1)?
            .parse()
            .ok()?;
        kb.checked_mul(1024)
    });
    let read_u64 = |p: &str| -> Option<u64> {
        gloam_io::read_text(std::path::Path::new(p), 1 << 16, &gloam_io::ReadLog::off())
            .ok()?
            .trim()
            .parse()
            .ok()
    };
    let cgroup = read_u64("/sys/fs/cgroup/memory.max")
        .map(|max| max.saturating_sub(read_u64("/sys/fs/cgroup/memory.current").unwrap_or(0)));
    [
        meminfo.map(|b| (b, "MemAvailable")),
        cgroup.map(|b| (b, "the cgroup's memory.max")),
        address_space_room().map(|b| (b, "RLIMIT_AS (ulimit -v)")),
    ]
    .into_iter()
    .flatten()
    .min_by_key(|&(b, _)| b)
}

/// Bytes left under the soft `RLIMIT_AS` (`/proc/self/limits`, "Max
/// address space"): the limit less the process's resident memory
/// (`VmRSS`, `/proc/self/status`), of which a fifth is kept for address
/// space reserved but not yet used (the allocator's arenas, thread stacks:
/// `VmSize` is 1.4 GB at start under a 1.5 GB limit, yet 0.96 GB more
/// were allocated before the abort); `None` when unlimited or unreadable.
fn address_space_room() -> Option<u64> {
    let (soft, rss_kb) = (soft_address_limit()?, status_kb("VmRSS:")?);
    Some(soft.saturating_sub(rss_kb.saturating_mul(1024)) / 5 * 4)
}

/// The soft `RLIMIT_AS` in bytes (`/proc/self/limits`, "Max address
/// space"); `None` when unlimited or unreadable.
fn soft_address_limit() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?
        .trim_start_matches("Max address space")
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// A `/proc/self/status` figure in kB (`key` with its colon: `VmRSS:`).
fn status_kb(key: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status
        .lines()
        .find(|l| l.starts_with(key))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()
}

/// Bytes of address space left unreserved under the soft `RLIMIT_AS`
/// (`ulimit -v`): the limit less `VmSize`, what the limit counts. Thread
/// stacks are reserved whole, so a pool's stacks are checked against
/// this, not against [`available_memory`] (which counts resident memory).
/// `None` when unlimited or unreadable.
pub fn address_space_unreserved() -> Option<u64> {
    let (soft, size_kb) = (soft_address_limit()?, status_kb("VmSize:")?);
    Some(soft.saturating_sub(size_kb.saturating_mul(1024)))
}

/// Why an expansion does not fit: too many items, or not enough memory.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum BudgetError {
    #[error(
        "{count} {what} here{} would exceed the limit of {limit} {what} per scene",
        plus_before(*.before)
    )]
    TooMany {
        count: u128,
        before: usize,
        limit: usize,
        what: &'static str,
    },
    #[error(
        "{total} {what} need about {:.1} GB ({bytes_each} bytes each), more than the {:.1} GB of memory available",
        *.need_bytes as f64 / 1e9,
        *.available_bytes as f64 / 1e9
    )]
    Memory {
        total: u128,
        what: &'static str,
        bytes_each: usize,
        need_bytes: u128,
        available_bytes: u64,
    },
}

fn plus_before(before: usize) -> String {
    if before > 0 {
        format!(" plus {before} before it")
    } else {
        String::new()
    }
}

/// Checks that `count` items, `bytes_each` bytes each (on top of `before`
/// items already counted), stay within `limit` items and `available` bytes.
/// `what` names the items ("facets", "point sources").
pub(crate) fn check_budget(
    before: usize,
    count: u128,
    limit: usize,
    bytes_each: usize,
    available: Option<u64>,
    what: &'static str,
) -> Result<(), BudgetError> {
    let total = before as u128 + count;
    if total > limit as u128 {
        return Err(BudgetError::TooMany {
            count,
            before,
            limit,
            what,
        });
    }
    if let Some(avail) = available {
        let need = total * bytes_each as u128;
        if need > avail as u128 {
            return Err(BudgetError::Memory {
                total,
                what,
                bytes_each,
                need_bytes: need,
                available_bytes: avail,
            });
        }
    }
    Ok(())
}

/// Upper bound on the faces an OBJ text holds (lines starting with `f`),
/// counted before it is parsed so that an oversized mesh is refused before
/// the parser allocates for it.
pub(crate) fn count_obj_faces(bytes: &[u8]) -> usize {
    bytes
        .split(|&b| b == b'\n')
        .filter(|l| {
            let l = l.trim_ascii_start();
            l.first() == Some(&b'f') && l.get(1).is_some_and(|c| c.is_ascii_whitespace())
        })
        .count()
}
