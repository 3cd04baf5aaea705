//! Light groups: which emitters render into which layer (`gloam render
//! --layers`). Radiance is linear in each source's emission, so a render
//! split by group sums to the whole; the groups only name the split.
//!
//! Default granularity: one group per *source table* — each
//! `[point_sources.NAME]` (all its placements), each
//! `[distant_sources.NAME]`, and each `[objects.NAME]`
//! whose material emits (all its placements and facets) — because that is
//! what a scene author switches as one thing (a row of lamps written as one
//! instanced table is one circuit). `group = "NAME"` on a point or distant source,
//! an emissive object or an emissive material merges sources into a named
//! group (an object's own key wins over its material's). A scene with a
//! `[sky]` also has the groups `moon` (the direct beam) and `sky` (the
//! dome: night-sky glow and scattered light), and `sun` and `twilight`
//! when its Sun lights the scene; those four names are the sky's own and
//! no other source may be named or grouped so. Equal names are one group.

use std::collections::BTreeMap;

use crate::error::FieldPath;
use crate::raw::RawScene;
use crate::{DistantSource, Material, ObjectInfo, PointSourceGroup, SceneError, SkyConfig};

/// The moon's group name (the direct lunar beam).
pub const MOON_GROUP: &str = "moon";
/// The sky dome's group name (night-sky glow and scattered light).
pub const SKY_GROUP: &str = "sky";
/// The Sun's direct beam's group name.
pub const SUN_GROUP: &str = "sun";
/// The twilight sky's group name (sunlight scattered by the sky).
pub const TWILIGHT_GROUP: &str = "twilight";

/// The groups a `[sky]` renders into; with a `[sky]` no other source
/// may be named or grouped so.
pub const SKY_GROUPS: [&str; 4] = [MOON_GROUP, SKY_GROUP, SUN_GROUP, TWILIGHT_GROUP];

/// One light group: its name and the scene tables it gathers
/// (`point_sources.NAME`, `objects.NAME`, `sky.moon`, `sky.dome`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LightGroup {
    pub name: String,
    pub sources: Vec<String>,
}

/// The scene's light groups and each source's group index.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightGroups {
    /// In order of first appearance: objects, point sources, distant
    /// sources, moon, sky.
    pub groups: Vec<LightGroup>,
    /// Per [`crate::Scene::objects`] entry: its group, `None` when its
    /// material does not emit.
    pub object: Vec<Option<usize>>,
    /// Per [`crate::Scene::point_source_groups`] entry (table).
    pub point_table: Vec<usize>,
    /// Per [`crate::Scene::distant_sources`] entry.
    pub distant: Vec<usize>,
    /// The moon's and the sky dome's groups (with a `[sky]`).
    pub moon: Option<usize>,
    pub sky: Option<usize>,
    /// The Sun's beam and the twilight sky (with a `[sky]` whose Sun is
    /// up, or at or above −18°).
    pub sun: Option<usize>,
    pub twilight: Option<usize>,
}

impl LightGroups {
    fn index(&mut self, name: &str, source: String) -> usize {
        let i = match self.groups.iter().position(|g| g.name == name) {
            Some(i) => i,
            None => {
                self.groups.push(LightGroup {
                    name: name.to_string(),
                    sources: Vec::new(),
                });
                self.groups.len() - 1
            }
        };
        self.groups[i].sources.push(source);
        i
    }

    /// Gives the sky's Sun its groups (`sun` for its beam, `twilight` for
    /// its sky) where they are missing: a sequence whose clock carries the
    /// Sun across the horizon or −18° renders every instant into the same
    /// groups, empty where the Sun does not light them.
    pub fn with_sunlight(&mut self, beam: bool, twilight: bool) {
        if beam && self.sun.is_none() {
            self.sun = Some(self.index(SUN_GROUP, "sky.sun".into()));
        }
        if twilight && self.twilight.is_none() {
            self.twilight = Some(self.index(TWILIGHT_GROUP, "sky.twilight".into()));
        }
    }
}

/// A light group name that cannot be a file name or a JSON key.
#[derive(Debug, thiserror::Error)]
#[error("light group name '{0}': use 1 to 100 of A-Z a-z 0-9 - _ . (not starting with '.')")]
struct BadGroupName(String);

/// A group name becomes a file name and a JSON key: plain characters only.
fn check_name(name: &str) -> Result<(), BadGroupName> {
    let plain = |c: char| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.');
    if name.is_empty() || name.len() > 100 || !name.chars().all(plain) || name.starts_with('.') {
        return Err(BadGroupName(name.to_string()));
    }
    Ok(())
}

pub(crate) fn light_groups(
    raw: &RawScene,
    materials: &[Material],
    objects: &[ObjectInfo],
    point_tables: &[PointSourceGroup],
    distant: &[DistantSource],
    sky: Option<&SkyConfig>,
    err: &dyn Fn(&FieldPath, String) -> SceneError,
) -> Result<LightGroups, SceneError> {
    let root = FieldPath::root();
    let named = |field: FieldPath, g: &Option<String>| -> Result<Option<String>, SceneError> {
        match g {
            Some(n) => check_name(n)
                .map(|_| Some(n.clone()))
                .map_err(|m| err(&field, m.to_string())),
            None => Ok(None),
        }
    };
    let mut mat_group: BTreeMap<&str, Option<String>> = BTreeMap::new();
    for (name, m) in &raw.materials {
        let g = named(root.key("materials").key(name).key("group"), &m.group)?;
        mat_group.insert(name.as_str(), g);
    }
    // With a `[sky]` its groups' names are its own: a lamp named or grouped
    // `moon` would otherwise join the Moon's layer (and a sequence keying
    // `moon` would dim both).
    let has_sky = raw.sky.is_some();
    let reserved = |field: &FieldPath, name: &str| -> Result<(), SceneError> {
        if has_sky && SKY_GROUPS.contains(&name) {
            return Err(err(
                field,
                format!(
                    "light group '{name}' is the sky's own (with a [sky], {} name its moon, dome, Sun and twilight layers): give this source another group name",
                    SKY_GROUPS.join(", ")
                ),
            ));
        }
        Ok(())
    };
    let mut out = LightGroups::default();
    for o in objects {
        let field = root.key("objects").key(&o.name);
        let own = raw.objects.get(&o.name).and_then(|r| r.group.clone());
        let own = named(field.key("group"), &own)?;
        if materials[o.material].emission.is_none() {
            if own.is_some() {
                return Err(err(
                    &field.key("group"),
                    format!(
                        "object '{}' does not emit: a light group needs an emissive material",
                        o.name
                    ),
                ));
            }
            out.object.push(None);
            continue;
        }
        let mat = mat_group
            .get(materials[o.material].name.as_str())
            .cloned()
            .flatten();
        let blame = match (&own, &mat) {
            (Some(_), _) => field.key("group"),
            (None, Some(_)) => root
                .key("materials")
                .key(&materials[o.material].name)
                .key("group"),
            (None, None) => field.clone(),
        };
        let name = own.or(mat).unwrap_or_else(|| o.name.clone());
        check_name(&name).map_err(|m| err(&field, m.to_string()))?;
        reserved(&blame, &name)?;
        let i = out.index(&name, format!("objects.{}", o.name));
        out.object.push(Some(i));
    }
    for t in point_tables {
        let field = root.key("point_sources").key(&t.name);
        let own = raw.point_sources.get(&t.name).and_then(|r| r.group.clone());
        let blame = if own.is_some() {
            field.key("group")
        } else {
            field.clone()
        };
        let name = named(field.key("group"), &own)?.unwrap_or_else(|| t.name.clone());
        check_name(&name).map_err(|m| err(&field, m.to_string()))?;
        reserved(&blame, &name)?;
        let i = out.index(&name, format!("point_sources.{}", t.name));
        out.point_table.push(i);
    }
    for d in distant {
        let name = &d.name;
        let field = root.key("distant_sources").key(name);
        let own = raw.distant_sources.get(name).and_then(|r| r.group.clone());
        let blame = if own.is_some() {
            field.key("group")
        } else {
            field.clone()
        };
        let group = named(field.key("group"), &own)?.unwrap_or_else(|| name.clone());
        check_name(&group).map_err(|m| err(&field, m.to_string()))?;
        reserved(&blame, &group)?;
        let i = out.index(&group, format!("distant_sources.{name}"));
        out.distant.push(i);
    }
    if raw.sky.is_some() {
        out.moon = Some(out.index(MOON_GROUP, "sky.moon".into()));
        out.sky = Some(out.index(SKY_GROUP, "sky.dome".into()));
    }
    if let Some(s) = sky {
        if s.sun_beam() {
            out.sun = Some(out.index(SUN_GROUP, "sky.sun".into()));
        }
        if s.twilight() {
            out.twilight = Some(out.index(TWILIGHT_GROUP, "sky.twilight".into()));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    const BASE: &str = r#"
units = "m"
[camera]
position = [0, 0, 5]
look_at = [0, 1, 0]
fov_deg = 60
width = 4
height = 4
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.grey]
reflectance = 0.5
[materials.glow]
reflectance = 0.0
emission = { value = 1.0 }
[objects.floor]
material = "grey"
quad = { center = [0, 0, 0], size = [4, 4], normal = [0, 0, 1] }
"#;

    fn parse(extra: &str) -> Result<crate::Scene, crate::SceneError> {
        crate::parse_str(&format!("{BASE}{extra}"), Path::new("t.toml"))
    }

    fn names(s: &crate::Scene) -> Vec<&str> {
        s.light_groups
            .groups
            .iter()
            .map(|g| g.name.as_str())
            .collect()
    }

    #[test]
    fn one_group_per_table_merged_by_key_then_moon_and_sky() {
        let s = parse(
            r#"
[objects.panel]
material = "glow"
quad = { center = [0, 0, 2], size = [1, 1], normal = [0, 0, -1] }
[point_sources.a]
position = [1, 0, 2]
value = 1
instances = [{ translate = [0, 0, 0] }, { translate = [1, 0, 0] }]
[point_sources.b]
position = [2, 0, 2]
value = 1
group = "panel"
[sky]
utc = "2025-10-07T05:00:00Z"
latitude_deg = 43
longitude_deg = -77
"#,
        )
        .unwrap();
        assert_eq!(names(&s), ["panel", "a", "moon", "sky"]);
        let g = &s.light_groups;
        assert_eq!(g.object, [None, Some(0)]);
        assert_eq!(g.point_table, [1, 0]);
        assert_eq!((g.moon, g.sky), (Some(2), Some(3)));
        assert_eq!(g.groups[0].sources, ["objects.panel", "point_sources.b"]);
    }

    #[test]
    fn a_material_names_its_objects_group_and_an_object_overrides_it() {
        let s = parse(
            r#"
[objects.p1]
material = "glow2"
quad = { center = [0, 0, 2], size = [1, 1], normal = [0, 0, -1] }
[objects.p2]
material = "glow2"
group = "own"
quad = { center = [1, 0, 2], size = [1, 1], normal = [0, 0, -1] }
[materials.glow2]
reflectance = 0.0
emission = { value = 1.0 }
group = "signs"
"#,
        )
        .unwrap();
        assert_eq!(names(&s), ["signs", "own"]);
    }

    #[test]
    fn groups_on_non_emitters_and_unplain_names_are_refused() {
        assert!(parse("").is_ok());
        let bad = BASE.replace(
            "[objects.floor]\nmaterial = \"grey\"",
            "[objects.floor]\nmaterial = \"grey\"\ngroup = \"x\"",
        );
        let e = crate::parse_str(&bad, Path::new("t.toml")).unwrap_err();
        assert_eq!(e.field(), "objects.floor.group");
        let e = parse("[point_sources.a]\nposition = [0, 0, 1]\nvalue = 1\ngroup = \"../up\"\n")
            .unwrap_err();
        assert_eq!(e.field(), "point_sources.a.group");
    }

    #[test]
    fn the_skys_group_names_are_refused_for_other_sources_with_a_sky() {
        let sky = "[sky]\nutc = \"2025-10-07T05:00:00Z\"\nlatitude_deg = 43\nlongitude_deg = -77\n";
        let glow_moon = "[objects.panel]\nmaterial = \"glow\"\nquad = { center = [0, 0, 2], size = [1, 1], normal = [0, 0, -1] }\n[materials.glow2]\nreflectance = 0.0\nemission = { value = 1.0 }\ngroup = \"moon\"\n[objects.p2]\nmaterial = \"glow2\"\nquad = { center = [1, 0, 2], size = [1, 1], normal = [0, 0, -1] }\n";
        for (extra, field) in [
            (
                "[point_sources.moon]\nposition = [0, 0, 1]\nvalue = 1\n",
                "point_sources.moon",
            ),
            (
                "[point_sources.a]\nposition = [0, 0, 1]\nvalue = 1\ngroup = \"sky\"\n",
                "point_sources.a.group",
            ),
            (
                "[distant_sources.sun]\ndirection = [0, 0, -1]\nvalue = 1\n",
                "distant_sources.sun",
            ),
            (
                "[distant_sources.d]\ndirection = [0, 0, -1]\nvalue = 1\ngroup = \"moon\"\n",
                "distant_sources.d.group",
            ),
            (
                "[objects.twilight]\nmaterial = \"glow\"\nquad = { center = [0, 0, 2], size = [1, 1], normal = [0, 0, -1] }\n",
                "objects.twilight",
            ),
            (glow_moon, "materials.glow2.group"),
        ] {
            let e = parse(&format!("{extra}{sky}")).unwrap_err();
            assert_eq!(e.field(), field, "{e}");
            assert!(e.to_string().contains("is the sky's own"), "{e}");
            // Without a [sky] the names are free.
            assert!(parse(extra).is_ok(), "{extra}");
        }
    }
}
