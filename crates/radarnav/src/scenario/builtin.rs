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

/// (name, TOML source) of the navigation trial maps (`scenarios/nav/`, DESIGN §6): each a
/// Bug mission on a map of a kind users draw first; `radarnav nav-suite` runs them all.
pub const NAV_SUITE: &[(&str, &str)] = &[
    (
        "nav/box-goal",
        include_str!("../../../../scenarios/nav/box-goal.toml"),
    ),
    (
        "nav/c-goal",
        include_str!("../../../../scenarios/nav/c-goal.toml"),
    ),
    (
        "nav/doorway",
        include_str!("../../../../scenarios/nav/doorway.toml"),
    ),
    (
        "nav/hall",
        include_str!("../../../../scenarios/nav/hall.toml"),
    ),
    (
        "nav/hedge-gap",
        include_str!("../../../../scenarios/nav/hedge-gap.toml"),
    ),
    (
        "nav/hedge-light",
        include_str!("../../../../scenarios/nav/hedge-light.toml"),
    ),
    (
        "nav/hedge-thin",
        include_str!("../../../../scenarios/nav/hedge-thin.toml"),
    ),
    (
        "nav/long-wall",
        include_str!("../../../../scenarios/nav/long-wall.toml"),
    ),
    (
        "nav/maze",
        include_str!("../../../../scenarios/nav/maze.toml"),
    ),
    (
        "nav/notch",
        include_str!("../../../../scenarios/nav/notch.toml"),
    ),
    (
        "nav/pen-goal",
        include_str!("../../../../scenarios/nav/pen-goal.toml"),
    ),
    (
        "nav/pen-start",
        include_str!("../../../../scenarios/nav/pen-start.toml"),
    ),
    (
        "nav/pillar",
        include_str!("../../../../scenarios/nav/pillar.toml"),
    ),
    (
        "nav/row",
        include_str!("../../../../scenarios/nav/row.toml"),
    ),
    (
        "nav/slab",
        include_str!("../../../../scenarios/nav/slab.toml"),
    ),
    (
        "nav/smoke-band",
        include_str!("../../../../scenarios/nav/smoke-band.toml"),
    ),
    (
        "nav/smoke-cloud",
        include_str!("../../../../scenarios/nav/smoke-cloud.toml"),
    ),
    (
        "nav/thicket",
        include_str!("../../../../scenarios/nav/thicket.toml"),
    ),
    (
        "nav/u-away",
        include_str!("../../../../scenarios/nav/u-away.toml"),
    ),
    (
        "nav/u-toward",
        include_str!("../../../../scenarios/nav/u-toward.toml"),
    ),
];

/// The TOML source of the built-in scenario `name` (a trial map is `nav/<name>`).
pub fn builtin_source(name: &str) -> Option<&'static str> {
    BUILTIN_SCENARIOS
        .iter()
        .chain(NAV_SUITE)
        .find(|(n, _)| *n == name)
        .map(|(_, s)| *s)
}
