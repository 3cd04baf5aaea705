//! Light groups: which emitters render into which layer (`gloam render
//! --layers`). Radiance is linear in each source's emission, so a render
//! split by group sums to the whole; the groups only name the split.
//!
//! Default granularity: one group per *source table* — each
//! `[point_sources.NAME]` (all its placements) and each `[objects.NAME]`
//! whose material emits (all its placements and facets) — because that is
//! what a scene author switches as one thing (a row of lamps written as one
//! instanced table is one circuit). `group = "NAME"` on a point source,
//! an emissive object or an emissive material merges sources into a named
//! group (an object's own key wins over its material's). A scene with a
//! `[sky]` also has the groups `moon` (the direct beam) and `sky` (the
//! dome: night-sky glow and scattered light). Equal names are one group.

use std::collections::BTreeMap;

use crate::error::FieldPath;
use crate::raw::RawScene;
use crate::{Material, ObjectInfo, PointSourceGroup, SceneError};

/// The moon's group name (the direct lunar beam).
pub const MOON_GROUP: &str = "moon";
/// The sky dome's group name (night-sky glow and scattered light).
pub const SKY_GROUP: &str = "sky";

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
    /// In order of first appearance: objects, point sources, moon, sky.
    pub groups: Vec<LightGroup>,
    /// Per [`crate::Scene::objects`] entry: its group, `None` when its
    /// material does not emit.
    pub object: Vec<Option<usize>>,
    /// Per [`crate::Scene::point_source_groups`] entry (table).
    pub point_table: Vec<usize>,
    /// The moon's and the sky dome's groups (with a `[sky]`).
    pub moon: Option<usize>,
    pub sky: Option<usize>,
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
}

/// A group name becomes a file name and a JSON key: plain characters only.
fn check_name(name: &str) -> Result<(), String> {
    let plain = |c: char| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.');
    if name.is_empty() || name.len() > 100 || !name.chars().all(plain) || name.starts_with('.') {
        return Err(format!(
            "light group name '{name}': use 1 to 100 of A-Z a-z 0-9 - _ . (not starting with '.')"
        ));
    }
    Ok(())
}

pub(crate) fn light_groups(
    raw: &RawScene,
    materials: &[Material],
    objects: &[ObjectInfo],
    point_tables: &[PointSourceGroup],
    err: &dyn Fn(&FieldPath, String) -> SceneError,
) -> Result<LightGroups, SceneError> {
    let root = FieldPath::root();
    let named = |field: FieldPath, g: &Option<String>| -> Result<Option<String>, SceneError> {
        match g {
            Some(n) => check_name(n)
                .map(|_| Some(n.clone()))
                .map_err(|m| err(&field, m)),
            None => Ok(None),
        }
    };
    let mut mat_group: BTreeMap<&str, Option<String>> = BTreeMap::new();
    for (name, m) in &raw.materials {
        let g = named(root.key("materials").key(name).key("group"), &m.group)?;
        mat_group.insert(name.as_str(), g);
    }
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
        let name = own.or(mat).unwrap_or_else(|| o.name.clone());
        check_name(&name).map_err(|m| err(&field, m))?;
        let i = out.index(&name, format!("objects.{}", o.name));
        out.object.push(Some(i));
    }
    for t in point_tables {
        let field = root.key("point_sources").key(&t.name);
        let own = raw.point_sources.get(&t.name).and_then(|r| r.group.clone());
        let name = named(field.key("group"), &own)?.unwrap_or_else(|| t.name.clone());
        check_name(&name).map_err(|m| err(&field, m))?;
        let i = out.index(&name, format!("point_sources.{}", t.name));
        out.point_table.push(i);
    }
    if raw.sky.is_some() {
        out.moon = Some(out.index(MOON_GROUP, "sky.moon".into()));
        out.sky = Some(out.index(SKY_GROUP, "sky.dome".into()));
    }
    Ok(out)
}
