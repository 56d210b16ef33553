//! Every schema text starts with the type's own fields, contains each dependency exactly
//! once after the 80-`=` separator, and misses none.

use std::collections::BTreeSet;

use msgs::Msg;
use msgs::schema::{ALL_DEFINITIONS, SEPARATOR, definition};

const PRIMITIVES: &[&str] = &[
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
    "uint32", "int64", "uint64", "string", "wstring",
];

/// Non-primitive field types of one `.msg` section, resolved to `pkg/Type`.
fn referenced_types(pkg: &str, text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        let Some(ty) = line.split_whitespace().next() else {
            continue;
        };
        let base = ty.split(['[', '<']).next().unwrap_or(ty);
        if PRIMITIVES.contains(&base) {
            continue;
        }
        let full = if base.contains('/') {
            base.replace("/msg/", "/")
        } else if base == "Header" {
            "std_msgs/Header".to_string()
        } else {
            format!("{pkg}/{base}")
        };
        out.push(full);
    }
    out
}

fn check_schema(type_name: &str, schema: &str) {
    let own = definition(type_name).expect("definition");
    let sep = format!("\n{SEPARATOR}\n");
    let mut sections = schema.split(sep.as_str());
    let first = sections.next().expect("own section");
    assert_eq!(
        first.trim_end(),
        own.text.trim_end(),
        "{type_name}: own text first"
    );
    let mut names: Vec<(String, String)> = vec![(own.name.to_string(), first.to_string())];
    for section in sections {
        let (head, body) = section.split_once('\n').unwrap_or((section, ""));
        let name = head
            .strip_prefix("MSG: ")
            .unwrap_or_else(|| panic!("{type_name}: section header {head:?}"));
        assert!(
            !names.iter().any(|(n, _)| n == name),
            "{type_name}: {name} twice"
        );
        let def = definition(name).unwrap_or_else(|| panic!("{name} unknown"));
        assert_eq!(
            body.trim_end(),
            def.text.trim_end(),
            "{type_name}: text of {name}"
        );
        names.push((name.to_string(), body.to_string()));
    }
    let present: BTreeSet<&str> = names.iter().map(|(n, _)| n.as_str()).collect();
    let mut referenced = BTreeSet::new();
    for (name, body) in &names {
        let pkg = name.split('/').next().unwrap_or("");
        for dep in referenced_types(pkg, body) {
            assert!(
                present.contains(dep.as_str()),
                "{type_name}: {name} uses {dep}, which has no MSG: section"
            );
            referenced.insert(dep);
        }
    }
    // No superfluous sections either: every dependency section is referenced.
    for name in &present {
        if *name != own.name {
            assert!(
                referenced.contains(*name),
                "{type_name}: {name} not referenced"
            );
        }
    }
    assert!(schema.ends_with('\n'));
}

#[test]
fn every_msg_schema_is_complete_and_deduplicated() {
    for type_name in Msg::TYPE_NAMES {
        let schema = Msg::schema_text(type_name).expect("schema");
        check_schema(type_name, &schema);
    }
}

#[test]
fn every_definition_schema_is_complete() {
    for def in ALL_DEFINITIONS {
        check_schema(def.name, &def.schema_text());
    }
}

#[test]
fn path_schema_has_header_and_time_once() {
    let schema = Msg::schema_text("nav_msgs/msg/Path").expect("schema");
    assert_eq!(schema.matches("MSG: std_msgs/Header\n").count(), 1);
    assert_eq!(schema.matches("MSG: builtin_interfaces/Time\n").count(), 1);
    assert_eq!(schema.matches("MSG: geometry_msgs/Quaternion\n").count(), 1);
    assert_eq!(schema.matches(SEPARATOR).count(), 6, "{schema}");
    assert_eq!(SEPARATOR.len(), 80);
    assert!(SEPARATOR.chars().all(|c| c == '='));
}

#[test]
fn constants_are_kept_in_schema_text() {
    let log = Msg::schema_text("rcl_interfaces/msg/Log").expect("schema");
    assert!(log.contains("byte DEBUG=10") && log.contains("byte FATAL=50"));
    let clamp = Msg::schema_text("rodlog_msgs/msg/ClampCommand").expect("schema");
    assert!(clamp.contains("uint8 CLOSE=1"));
    let ev = Msg::schema_text("rodlog_msgs/msg/TaskEvent").expect("schema");
    assert!(ev.contains("uint8 DONE=3"));
    let cloud = Msg::schema_text("sensor_msgs/msg/PointCloud2").expect("schema");
    assert!(cloud.contains("uint8 FLOAT64 = 8"));
}

#[test]
fn the_checker_catches_a_missing_dependency() {
    let schema = Msg::schema_text("geometry_msgs/msg/PoseStamped").expect("schema");
    // Drop the last section (whatever it is): the check must fail.
    let cut = schema
        .rfind(&format!("\n{SEPARATOR}\n"))
        .expect("has sections");
    let broken = format!("{}\n", &schema[..cut]);
    let result = std::panic::catch_unwind(|| check_schema("geometry_msgs/PoseStamped", &broken));
    assert!(result.is_err());
}
