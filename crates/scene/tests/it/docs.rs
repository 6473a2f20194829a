//! docs/scene-format.md lists exactly the keys the parser accepts, and its
//! default column agrees with the constants in `relight_scene::file`.
//!
//! The parser's keys are read from the parser itself: every struct denies
//! unknown fields, so a probe file with an unknown key in a table makes
//! serde list that table's field names (`expected one of `a`, `b`, …`).
//! Sub-tables are found through their parent's documented type, and every
//! key of the parent must be documented, so a new table cannot hide.

use crate::common;

use relight_scene::file::*;
use std::collections::BTreeMap;
use std::path::Path;

/// One documented key: its type cell and default cell.
struct Row {
    ty: String,
    default: String,
}

/// Section (table path, "" for the top level) → key → row.
fn documented() -> BTreeMap<String, BTreeMap<String, Row>> {
    let doc = std::fs::read_to_string(common::examples_dir().join("../docs/scene-format.md"))
        .expect("docs/scene-format.md");
    let keys = &doc[doc.find("\n## Keys").expect("a `## Keys` section")..];
    let keys = &keys[..keys[1..].find("\n## ").map_or(keys.len(), |i| i + 1)];
    let mut out: BTreeMap<String, BTreeMap<String, Row>> = BTreeMap::new();
    let mut section: Option<String> = None;
    for line in keys.lines() {
        if let Some(h) = line.strip_prefix("### ") {
            let name = if h.trim() == "Top level" {
                String::new()
            } else {
                h.trim()
                    .trim_matches('`')
                    .trim_matches(['[', ']'])
                    .to_string()
            };
            out.entry(name.clone()).or_default();
            section = Some(name);
        } else if let (Some(s), Some(rest)) = (&section, line.strip_prefix("| `")) {
            let cells: Vec<&str> = rest.split(" | ").collect();
            let key = cells[0].trim_end_matches('`').to_string();
            let row = Row {
                ty: cells[1].trim().to_string(),
                default: cells[3].trim().to_string(),
            };
            assert!(
                out.get_mut(s).unwrap().insert(key.clone(), row).is_none(),
                "`{key}` documented twice in [{s}]"
            );
        }
    }
    out
}

/// The parser's field names for table `path`, whose segments are arrays of
/// tables where `arrays` says so.
fn parser_keys(path: &str, arrays: &[bool]) -> Vec<String> {
    let mut text = String::new();
    let mut prefix = String::new();
    for (seg, is_array) in path.split('.').filter(|s| !s.is_empty()).zip(arrays) {
        if !prefix.is_empty() {
            prefix.push('.');
        }
        prefix.push_str(seg);
        text += &if *is_array {
            format!("[[{prefix}]]\n")
        } else {
            format!("[{prefix}]\n")
        };
    }
    text += "zz_not_a_key = 1\n";
    let e = parse_scene_file(&text, Path::new("probe.toml"))
        .err()
        .unwrap_or_else(|| panic!("the probe parsed:\n{text}"))
        .to_string();
    let list = if let Some((_, l)) = e.split_once("expected one of ") {
        l
    } else if let Some((_, l)) = e.split_once("expected ") {
        l
    } else {
        panic!("no field list in: {e}")
    };
    // serde: "`a`", "`a` or `b`", "one of `a`, `b`, `c`".
    list.split(", ")
        .flat_map(|k| k.split(" or "))
        .map(|k| k.trim().trim_matches('`').to_string())
        .collect()
}

#[test]
fn docs_list_every_key_the_parser_accepts() {
    let doc = documented();
    // Walk the tables from the top level; `arrays` marks arrays of tables.
    let mut todo = vec![(String::new(), Vec::<bool>::new())];
    let mut seen = Vec::new();
    while let Some((path, arrays)) = todo.pop() {
        let mut parser = parser_keys(&path, &arrays);
        parser.sort();
        let rows = doc
            .get(&path)
            .unwrap_or_else(|| panic!("docs have no section for [{path}]"));
        let documented: Vec<String> = rows.keys().cloned().collect();
        assert_eq!(
            documented, parser,
            "[{path}]: documented keys (left) differ from the parser's (right)"
        );
        for (key, row) in rows {
            let sub = if path.is_empty() {
                key.clone()
            } else {
                format!("{path}.{key}")
            };
            let is_array = row.ty == "array of tables";
            if is_array || row.ty == "table" {
                let mut a = arrays.clone();
                a.push(is_array);
                todo.push((sub, a));
            }
        }
        seen.push(path);
    }
    let extra: Vec<&String> = doc.keys().filter(|k| !seen.contains(k)).collect();
    assert!(
        extra.is_empty(),
        "documented sections the parser lacks: {extra:?}"
    );
    assert!(seen.len() >= 10, "{seen:?}");
}

#[test]
fn documented_defaults_are_the_constants() {
    let doc = documented();
    let cell = |table: &str, key: &str| -> &str {
        &doc[table]
            .get(key)
            .unwrap_or_else(|| panic!("[{table}] {key} undocumented"))
            .default
    };
    let expect = |table: &str, key: &str, value: String, name: &str| {
        let c = cell(table, key);
        let want = format!("`{value}` (`{name}`)");
        assert!(
            c.contains(&want),
            "[{table}] {key}: default `{c}` lacks {want}"
        );
    };
    expect(
        "",
        "visibility",
        format!("{DEFAULT_VISIBILITY:?}"),
        "DEFAULT_VISIBILITY",
    );
    expect(
        "environment",
        "builtin",
        format!("{DEFAULT_ENVIRONMENT:?}"),
        "DEFAULT_ENVIRONMENT",
    );
    expect(
        "environment",
        "scale",
        format!("{DEFAULT_ENV_SCALE:?}"),
        "DEFAULT_ENV_SCALE",
    );
    expect(
        "environment",
        "rotate",
        format!("{DEFAULT_ROTATE_DEG:?}"),
        "DEFAULT_ROTATE_DEG",
    );
    expect(
        "camera",
        "up",
        format!("{DEFAULT_CAMERA_UP:?}"),
        "DEFAULT_CAMERA_UP",
    );
    expect(
        "camera",
        "fov",
        format!("{DEFAULT_FOV_DEG:?}"),
        "DEFAULT_FOV_DEG",
    );
    expect(
        "camera",
        "size",
        format!("{DEFAULT_IMAGE_SIZE:?}"),
        "DEFAULT_IMAGE_SIZE",
    );
    for table in ["object", "object.keyframe"] {
        expect(
            table,
            "translate",
            format!("{DEFAULT_TRANSLATE:?}"),
            "DEFAULT_TRANSLATE",
        );
        expect(
            table,
            "rotate",
            format!("{DEFAULT_ROTATE_DEG:?}"),
            "DEFAULT_ROTATE_DEG",
        );
        expect(
            table,
            "scale",
            format!("{DEFAULT_OBJECT_SCALE:?}"),
            "DEFAULT_OBJECT_SCALE",
        );
    }
    expect(
        "object",
        "brdf",
        format!("{DEFAULT_BRDF:?}"),
        "DEFAULT_BRDF",
    );
    expect(
        "point_light",
        "color",
        format!("{DEFAULT_LIGHT_COLOR:?}"),
        "DEFAULT_LIGHT_COLOR",
    );
    expect(
        "area_light",
        "up",
        format!("{DEFAULT_AREA_UP:?}"),
        "DEFAULT_AREA_UP",
    );
    expect(
        "area_light",
        "up",
        format!("{DEFAULT_AREA_UP_VERTICAL:?}"),
        "DEFAULT_AREA_UP_VERTICAL",
    );
    expect(
        "medium",
        "albedo",
        format!("{DEFAULT_MEDIUM_ALBEDO:?}"),
        "DEFAULT_MEDIUM_ALBEDO",
    );
    expect(
        "medium",
        "radius",
        format!("{DEFAULT_MEDIUM_RADIUS:?}"),
        "DEFAULT_MEDIUM_RADIUS",
    );
    assert!(cell("area_light", "up").contains(&format!("{VERTICAL_NORMAL_COS}")));
}
