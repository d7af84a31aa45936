//! Reading one set file's TOML: every field checked, unknown keys refused
//! (a typo in an optional field must not pass silently), errors that name
//! the set, the entry and the field.

use super::*;

/// Reads fields of one TOML table, remembering which were used so unknown
/// keys are reported (a typo in an optional field must not pass silently).
pub(super) struct Fields<'a> {
    table: &'a toml::Table,
    used: Vec<&'static str>,
    set: &'a str,
    index: usize,
    name: String,
}

impl<'a> Fields<'a> {
    pub(super) fn new(table: &'a toml::Table, set: &'a str, index: usize, name: &str) -> Self {
        Self {
            table,
            used: Vec::new(),
            set,
            index,
            name: name.to_string(),
        }
    }

    pub(super) fn err(&self, problem: String) -> MeasureError {
        MeasureError::Definition {
            set: self.set.to_string(),
            index: self.index,
            name: self.name.clone(),
            problem,
        }
    }

    pub(super) fn opt_string(&mut self, key: &'static str) -> Result<Option<String>, MeasureError> {
        self.used.push(key);
        match self.table.get(key) {
            None => Ok(None),
            Some(toml::Value::String(s)) if !s.trim().is_empty() => Ok(Some(s.clone())),
            Some(toml::Value::String(_)) => Err(self.err(format!("`{key}` is empty"))),
            Some(v) => Err(self.err(format!("`{key}` must be a string, found {}", v.type_str()))),
        }
    }

    pub(super) fn string(&mut self, key: &'static str) -> Result<String, MeasureError> {
        self.opt_string(key)?
            .ok_or_else(|| self.err(format!("missing field `{key}`")))
    }

    pub(super) fn strings(
        &mut self,
        key: &'static str,
        min: usize,
    ) -> Result<Vec<String>, MeasureError> {
        self.used.push(key);
        let arr = match self.table.get(key) {
            None => return Err(self.err(format!("missing field `{key}` (a list of names)"))),
            Some(toml::Value::Array(a)) => a,
            Some(v) => {
                return Err(self.err(format!(
                    "`{key}` must be a list of names, found {}",
                    v.type_str()
                )))
            }
        };
        let mut out = Vec::with_capacity(arr.len());
        for v in arr {
            match v.as_str() {
                Some(s) if !s.trim().is_empty() => out.push(s.to_string()),
                _ => return Err(self.err(format!("`{key}` must hold non-empty strings only"))),
            }
        }
        if out.len() < min {
            return Err(self.err(format!(
                "`{key}` needs at least {min} names, found {}",
                out.len()
            )));
        }
        Ok(out)
    }

    pub(super) fn unit_vector(&mut self, key: &'static str) -> Result<Vec3, MeasureError> {
        self.used.push(key);
        let bad = |s: &Self| {
            s.err(format!(
                "`{key}` must be a vector of three numbers [x, y, z] (station frame: +X body's right, +Y front, +Z up)"
            ))
        };
        let arr = match self.table.get(key) {
            None => return Err(self.err(format!("missing field `{key}` ([x, y, z])"))),
            Some(toml::Value::Array(a)) if a.len() == 3 => a,
            Some(_) => return Err(bad(self)),
        };
        let mut v = [0.0; 3];
        for (k, x) in arr.iter().enumerate() {
            v[k] = match x {
                toml::Value::Float(f) => *f,
                toml::Value::Integer(i) => *i as f64,
                _ => return Err(bad(self)),
            };
        }
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if !n.is_finite() || n < 1e-9 {
            return Err(self.err(format!(
                "`{key}` must be a non-zero finite vector, found {v:?}"
            )));
        }
        Ok([v[0] / n, v[1] / n, v[2] / n])
    }

    pub(super) fn finish(self) -> Result<(), MeasureError> {
        for key in self.table.keys() {
            if !self.used.contains(&key.as_str()) {
                return Err(self.err(format!(
                    "unknown field `{key}` for this kind{}",
                    did_you_mean(key, self.used.iter().copied())
                )));
            }
        }
        Ok(())
    }
}

const KINDS: [&str; 9] = [
    "euclidean",
    "path",
    "geodesic",
    "geodesic_path",
    "geodesic_loop",
    "circumference",
    "height",
    "breadth",
    "depth",
];

fn is_snake_case(s: &str) -> bool {
    !s.is_empty()
        && s.starts_with(|c: char| c.is_ascii_lowercase())
        && s.chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
}

fn method(f: &mut Fields<'_>) -> Result<GeodesicMethod, MeasureError> {
    match f.opt_string("method")?.as_deref() {
        None | Some("edges") => Ok(GeodesicMethod::Edges),
        Some("unfolded") => Ok(GeodesicMethod::Unfolded),
        Some(other) => Err(f.err(format!(
            "unknown geodesic method `{other}`{}; methods are: edges (Dijkstra on edges, the paper's), unfolded (also straight across triangle pairs)",
            did_you_mean(other, ["edges", "unfolded"])
        ))),
    }
}

pub(super) fn parse_definition(
    t: &toml::Table,
    set: &str,
    index: usize,
) -> Result<Definition, MeasureError> {
    let name_for_errors = t
        .get("name")
        .and_then(|v| v.as_str())
        .unwrap_or("?")
        .to_string();
    let mut f = Fields::new(t, set, index, &name_for_errors);
    let name = f.string("name")?;
    if !is_snake_case(&name) {
        return Err(f.err(
            "`name` must be snake_case (lowercase letters, digits and `_`, starting with a letter)"
                .into(),
        ));
    }
    let label = f.string("label")?;
    let description = f.string("description")?;
    let kind_name = f.string("kind")?;
    let kind = match kind_name.as_str() {
        "euclidean" => Kind::Euclidean {
            from: f.string("from")?,
            to: f.string("to")?,
        },
        "geodesic" => Kind::Geodesic {
            from: f.string("from")?,
            to: f.string("to")?,
            method: method(&mut f)?,
        },
        "path" => Kind::Path {
            landmarks: f.strings("landmarks", 2)?,
        },
        "geodesic_path" => Kind::GeodesicPath {
            landmarks: f.strings("landmarks", 2)?,
            method: method(&mut f)?,
        },
        "geodesic_loop" => Kind::GeodesicLoop {
            landmarks: f.strings("landmarks", 2)?,
            method: method(&mut f)?,
        },
        "circumference" => Kind::Circumference {
            anchor: f.string("anchor")?,
            normal: f.unit_vector("normal")?,
            parts: f.strings("parts", 1)?,
            through: if t.contains_key("through") {
                let th = f.strings("through", 2)?;
                if th.len() != 2 {
                    return Err(f.err(format!(
                        "`through` names exactly two landmarks (the plane passes through the anchor and them), found {}",
                        th.len()
                    )));
                }
                th
            } else {
                Vec::new()
            },
        },
        "height" => Kind::Height {
            landmark: f.string("landmark")?,
            floor: f.opt_string("floor")?,
        },
        "breadth" | "depth" => {
            let anchor = f.string("anchor")?;
            let normal = f.unit_vector("normal")?;
            let parts = f.strings("parts", 1)?;
            let axis = f.unit_vector("axis")?;
            let dot = normal[0] * axis[0] + normal[1] * axis[1] + normal[2] * axis[2];
            if dot.abs() > 1e-6 {
                return Err(f.err(format!(
                    "`axis` {axis:?} must lie in the plane (perpendicular to `normal` {normal:?}); a caliper measures across the cut"
                )));
            }
            if kind_name == "breadth" {
                Kind::Breadth {
                    anchor,
                    normal,
                    parts,
                    axis,
                }
            } else {
                Kind::Depth {
                    anchor,
                    normal,
                    parts,
                    axis,
                }
            }
        }
        other => {
            return Err(f.err(format!(
                "unknown kind `{other}`{}; kinds are: {}",
                did_you_mean(other, KINDS),
                KINDS.join(", ")
            )))
        }
    };
    let class = match f.opt_string("class")? {
        None => kind.default_class(),
        Some(c) => Class::ALL
            .iter()
            .find(|(n, _)| *n == c)
            .map(|(_, v)| *v)
            .ok_or_else(|| {
                f.err(format!(
                    "unknown class `{c}`{}; classes are: {}",
                    did_you_mean(&c, Class::ALL.iter().map(|(n, _)| *n)),
                    Class::ALL.map(|(n, _)| n).join(", ")
                ))
            })?,
    };
    let tol = f.opt_string("tolerance")?.ok_or_else(|| {
        f.err(format!(
            "missing field `tolerance` (ISO 20685-1 class: {})",
            Tolerance::ALL.map(|(n, _)| n).join(", ")
        ))
    })?;
    let tolerance = Tolerance::ALL
        .iter()
        .find(|(n, _)| *n == tol)
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            f.err(format!(
                "unknown tolerance class `{tol}`{}; classes are: {}",
                did_you_mean(&tol, Tolerance::ALL.iter().map(|(n, _)| *n)),
                Tolerance::ALL.map(|(n, _)| n).join(", ")
            ))
        })?;
    let ansur = f.opt_string("ansur")?;
    if let Some(a) = &ansur {
        if !ANSUR_COLUMNS.contains(&a.as_str()) {
            return Err(f.err(format!(
                "`ansur` = `{a}` is not an ANSUR II column{}",
                did_you_mean(a, ANSUR_COLUMNS.iter().copied())
            )));
        }
    }
    let group = f.opt_string("group")?;
    let note = f.opt_string("note")?;
    f.finish()?;
    Ok(Definition {
        name,
        label,
        description,
        kind,
        class,
        tolerance,
        ansur,
        group,
        note,
    })
}
