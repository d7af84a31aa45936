//! Hand-made charts and the station's quick-set names, shared by the tests.

#![allow(dead_code)]

use tapeshape_sizes::{Chart, DimensionKind, KnownDimension};

/// The quick set's names with their kinds (host/measure/sets/quick.toml),
/// written out so that the unit tests do not depend on that file's order.
pub fn known() -> Vec<KnownDimension> {
    use DimensionKind::*;
    [
        ("stature", Length),
        ("chest", Girth),
        ("waist", Girth),
        ("hip", Girth),
        ("neck", Girth),
        ("inside_leg", Length),
        ("arm_length", Length),
        ("thigh", Girth),
        ("upper_arm", Girth),
    ]
    .into_iter()
    .map(|(n, k)| KnownDimension::new(n, k))
    .collect()
}

/// A chart in cm: a shirt (chest; sleeve secondary) S/M/L/XL at 8 cm
/// steps from 88 to 120, trousers on a full 2 x 2 grid (waist 76-84-92,
/// inside leg 76-80-84), and a dress on the diagonal (chest and hip move
/// together in 4 cm steps).
pub const HAND_MADE: &str = r#"
[chart]
name = "hand-made test chart"
units = "cm"
description = "Known answers for the tests."

[[garment]]
name = "shirt"
primary = ["chest"]
secondary = ["arm_length"]

[[garment.size]]
label = "S"
chest = [88, 96]
arm_length = [58, 62]

[[garment.size]]
label = "M"
chest = [96, 104]
arm_length = [60, 64]

[[garment.size]]
label = "L"
chest = [104, 112]
arm_length = [62, 66]

[[garment.size]]
label = "XL"
chest = [112, 120]

[[garment]]
name = "trousers"
primary = ["waist", "inside_leg"]
secondary = ["hip"]
size = [
    { label = "W80/L78", waist = [76, 84], inside_leg = [76, 80], hip = [90, 100] },
    { label = "W80/L82", waist = [76, 84], inside_leg = [80, 84] },
    { label = "W88/L78", waist = [84, 92], inside_leg = [76, 80] },
    { label = "W88/L82", waist = [84, 92], inside_leg = [80, 84] },
]

[[garment]]
name = "dress"
primary = ["chest", "hip"]
size = [
    { label = "38", chest = [86, 90], hip = [94, 98] },
    { label = "40", chest = [90, 94], hip = [98, 102] },
    { label = "42", chest = [94, 98], hip = [102, 106] },
]
"#;

/// [`HAND_MADE`], parsed.
pub fn hand_made() -> Chart {
    Chart::from_toml_str(HAND_MADE, "hand-made.toml", &known())
        .expect("the hand-made chart is valid")
}
