//! Scenarios compiled into the binary; the same files ship under `scenarios/`.

/// (name, TOML source) of every built-in scenario.
pub const BUILTIN_SCENARIOS: &[(&str, &str)] = &[
    (
        "foliage-wall",
        include_str!("../../../../scenarios/foliage-wall.toml"),
    ),
    (
        "smoke-room",
        include_str!("../../../../scenarios/smoke-room.toml"),
    ),
    (
        "open-field",
        include_str!("../../../../scenarios/open-field.toml"),
    ),
    (
        "foliage-gap",
        include_str!("../../../../scenarios/foliage-gap.toml"),
    ),
    (
        "bug1-path",
        include_str!("../../../../scenarios/bug1-path.toml"),
    ),
    (
        "bug1-enclosed",
        include_str!("../../../../scenarios/bug1-enclosed.toml"),
    ),
    (
        "bug2-path",
        include_str!("../../../../scenarios/bug2-path.toml"),
    ),
    (
        "bug2-enclosed",
        include_str!("../../../../scenarios/bug2-enclosed.toml"),
    ),
    (
        "bug-spiral",
        include_str!("../../../../scenarios/bug-spiral.toml"),
    ),
];

/// The TOML source of the built-in scenario `name`.
pub fn builtin_source(name: &str) -> Option<&'static str> {
    BUILTIN_SCENARIOS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, s)| *s)
}
