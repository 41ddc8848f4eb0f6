//! The model TOML format (README "Model TOML"), read into and written from the core's
//! [`InsModel`].
//!
//! ```
//! let text = r#"
//! dt = 1.0
//! [observation]
//! sigma_v = 0.03
//! [[accel]]
//! kind = "gauss-markov"
//! sigma = 1e-3
//! tau = 100.0
//! "#;
//! let m = hal_sim::model_toml::parse(text, "inline.toml").unwrap();
//! assert_eq!(m.accel.len(), 1);
//! ```

use anyhow::{anyhow, Context, Result};
use imu_ident::model::{Component, ComponentKind, GaussMarkov, InsModel, Quantity};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// `observation.sigma_v` written to `model.toml`: a static recording has no velocity
/// reference, so this is a placeholder (the diagnosis' default of 3 cm/s) to be replaced by
/// the real aiding noise before `hal-sim run` is used on a moving log.
pub const SIGMA_V_PLACEHOLDER: f64 = 0.03;

/// One component as written in TOML: `kind = "<name>"` and the kind's quantities, all read and
/// written through the core's kind table ([`ComponentKind`]: `name`, `quantities` in file
/// order, `required`), so a kind added to the table needs no change here. An optional
/// quantity (a random walk's `sigma0`) is zero when absent and left out when zero. Not
/// validated: [`ComponentToml::to_core`] checks the parameters.
///
/// ```
/// use hal_sim::model_toml::ComponentToml;
/// use imu_ident::model::{Component, RandomWalk};
/// let c = ComponentToml(Component::RandomWalk(RandomWalk { q: 0.25, sigma0: 0.0 }));
/// assert_eq!(toml::to_string(&c).unwrap(), "kind = \"random-walk\"\nq = 0.25\n");
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ComponentToml(pub Component<f64>);

impl From<Component<f64>> for ComponentToml {
    fn from(c: Component<f64>) -> Self {
        Self(c)
    }
}

impl Serialize for ComponentToml {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let kind = self.0.kind();
        let fields = || {
            kind.quantities().iter().filter_map(|&q| {
                let v = self.0.get(q).unwrap_or(0.0);
                (kind.required(q) || v != 0.0).then_some((q, v))
            })
        };
        let mut st = s.serialize_struct("ComponentToml", 1 + fields().count())?;
        st.serialize_field("kind", kind.name())?;
        for (q, v) in fields() {
            st.serialize_field(q.name(), &v)?;
        }
        st.end()
    }
}

impl<'de> Deserialize<'de> for ComponentToml {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_map(ComponentVisitor)
    }
}

/// `` `a` ``, `` `a` or `b` ``, `` one of `a`, `b`, `c` ``: serde's wording of the expected
/// names in an error.
fn one_of<'a>(names: impl ExactSizeIterator<Item = &'a str>) -> String {
    let n = names.len();
    let list: Vec<String> = names.map(|x| format!("`{x}`")).collect();
    match n {
        1 | 2 => list.join(" or "),
        _ => format!("one of {}", list.join(", ")),
    }
}

/// The `kind` value: a name of the core's table.
struct KindName(ComponentKind);

impl<'de> Deserialize<'de> for KindName {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = KindName;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("variant identifier")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<KindName, E> {
                ComponentKind::from_name(v).map(KindName).ok_or_else(|| {
                    let names = ComponentKind::ALL.iter().map(|k| k.name());
                    E::custom(format_args!(
                        "unknown variant `{v}`, expected {}",
                        one_of(names)
                    ))
                })
            }
        }
        d.deserialize_identifier(V)
    }
}

/// A value of a component table, held until the kind is known (it may come last).
enum Value {
    Float(f64),
    Signed(i64),
    Unsigned(u64),
    Bool(bool),
    Str(String),
    Seq,
    Map,
    Other,
}

impl Value {
    /// The number, or serde's "invalid type" error.
    fn number<E: serde::de::Error>(&self) -> Result<f64, E> {
        use serde::de::Unexpected as U;
        let unexpected = match self {
            Self::Float(x) => return Ok(*x),
            Self::Signed(x) => return Ok(*x as f64),
            Self::Unsigned(x) => return Ok(*x as f64),
            Self::Bool(b) => U::Bool(*b),
            Self::Str(s) => U::Str(s),
            Self::Seq => U::Seq,
            Self::Map => U::Map,
            Self::Other => U::Other("value"),
        };
        Err(E::invalid_type(unexpected, &"f64"))
    }
}

impl<'de> Deserialize<'de> for Value {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::{IgnoredAny, MapAccess, SeqAccess};
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Value;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a value")
            }
            fn visit_f64<E>(self, v: f64) -> Result<Value, E> {
                Ok(Value::Float(v))
            }
            fn visit_i64<E>(self, v: i64) -> Result<Value, E> {
                Ok(Value::Signed(v))
            }
            fn visit_u64<E>(self, v: u64) -> Result<Value, E> {
                Ok(Value::Unsigned(v))
            }
            fn visit_bool<E>(self, v: bool) -> Result<Value, E> {
                Ok(Value::Bool(v))
            }
            fn visit_str<E>(self, v: &str) -> Result<Value, E> {
                Ok(Value::Str(v.to_string()))
            }
            fn visit_unit<E>(self) -> Result<Value, E> {
                Ok(Value::Other)
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut a: A) -> Result<Value, A::Error> {
                while a.next_element::<IgnoredAny>()?.is_some() {}
                Ok(Value::Seq)
            }
            fn visit_map<A: MapAccess<'de>>(self, mut a: A) -> Result<Value, A::Error> {
                while a.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
                Ok(Value::Map)
            }
        }
        d.deserialize_any(V)
    }
}

/// Reads a component table: `kind` first (wherever it is), then each field in file order
/// against the kind's quantities, then the required ones that are missing.
struct ComponentVisitor;

impl<'de> serde::de::Visitor<'de> for ComponentVisitor {
    type Value = ComponentToml;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a component table with a `kind`")
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(
        self,
        mut map: A,
    ) -> Result<ComponentToml, A::Error> {
        use serde::de::Error;
        let mut kind = None;
        let mut fields: Vec<(String, Value)> = Vec::new();
        while let Some(key) = map.next_key::<String>()? {
            if key == "kind" {
                if kind.is_some() {
                    return Err(A::Error::duplicate_field("kind"));
                }
                kind = Some(map.next_value::<KindName>()?.0);
            } else {
                fields.push((key, map.next_value()?));
            }
        }
        let kind = kind.ok_or_else(|| A::Error::missing_field("kind"))?;
        let names = kind.quantities();
        let mut values = [None; Quantity::ALL.len()];
        for (key, value) in &fields {
            let Some(i) = names.iter().position(|q| q.name() == key) else {
                return Err(if names.is_empty() {
                    A::Error::custom(format_args!("unknown field `{key}`, there are no fields"))
                } else {
                    A::Error::custom(format_args!(
                        "unknown field `{key}`, expected {}",
                        one_of(names.iter().map(|q| q.name()))
                    ))
                });
            };
            if values[i].is_some() {
                return Err(A::Error::duplicate_field(names[i].name()));
            }
            values[i] = Some(value.number()?);
        }
        let mut v = [0.0; Quantity::ALL.len()];
        for (i, q) in names.iter().enumerate() {
            match values[i] {
                Some(x) => v[i] = x,
                None if kind.required(*q) => return Err(A::Error::missing_field(q.name())),
                None => {}
            }
        }
        Ok(ComponentToml(kind.with_quantities(&v[..names.len()])))
    }
}

/// A coloured observation-noise term: Gauss-Markov `sigma` [m/s], `tau` [s].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColoredToml {
    /// Must be "gauss-markov" when given.
    #[serde(default = "gm_kind")]
    pub kind: String,
    /// Standard deviation [m/s].
    pub sigma: f64,
    /// Correlation time [s].
    pub tau: f64,
}

fn gm_kind() -> String {
    ComponentKind::GaussMarkov.name().into()
}

/// `[observation]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObservationToml {
    /// White observation noise [m/s].
    pub sigma_v: f64,
    /// Coloured observation-noise components.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub colored: Vec<ColoredToml>,
}

/// `[initial]`: initial uncertainty of the INS states (optional).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialToml {
    /// Initial velocity-error sigma [m/s] (default: `sigma_v`).
    pub sigma_dv: Option<f64>,
    /// Initial tilt-error sigma [rad] (default 1e-4).
    pub sigma_delta: Option<f64>,
}

/// A whole model file. Scenario files use the same structure, plus `name`, `description` and
/// `hours`, which `run` ignores.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelToml {
    /// Scenario name (scenario files only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Free text (scenario files only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Default duration [h] (scenario files only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hours: Option<f64>,
    /// Filter step [s].
    pub dt: f64,
    /// Observation noise.
    pub observation: ObservationToml,
    /// Initial INS-state uncertainty.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial: Option<InitialToml>,
    /// Accelerometer error components [m/s^2].
    #[serde(default)]
    pub accel: Vec<ComponentToml>,
    /// Gyro drift components [rad/s].
    #[serde(default)]
    pub gyro: Vec<ComponentToml>,
}

impl ComponentToml {
    /// Converts to the core type, checking the parameters.
    pub fn to_core(&self) -> Result<Component<f64>> {
        self.0.validate()?;
        Ok(self.0)
    }

    /// From the core type.
    pub fn from_core(c: &Component<f64>) -> Self {
        Self(*c)
    }
}

impl ModelToml {
    /// Converts to the core model, naming the offending field on error.
    pub fn to_core(&self) -> Result<InsModel<f64>> {
        let mut m = InsModel::empty(self.dt, self.observation.sigma_v);
        for (i, c) in self.observation.colored.iter().enumerate() {
            if ComponentKind::from_name(&c.kind) != Some(ComponentKind::GaussMarkov) {
                return Err(anyhow!(
                    "observation.colored[{i}].kind: expected {:?}, found {:?}",
                    ComponentKind::GaussMarkov.name(),
                    c.kind
                ));
            }
            let g = GaussMarkov::new(c.sigma, c.tau)
                .map_err(|e| anyhow!("observation.colored[{i}]: {e:?}"))?;
            m.colored
                .push(g)
                .map_err(|_| anyhow!("observation.colored: too many components"))?;
        }
        for (name, src, dst) in [
            ("accel", &self.accel, &mut m.accel),
            ("gyro", &self.gyro, &mut m.gyro),
        ] {
            for (i, c) in src.iter().enumerate() {
                let core = c.to_core().with_context(|| format!("{name}[{i}]"))?;
                dst.push(core)
                    .map_err(|_| anyhow!("{name}[{i}]: too many components"))?;
            }
        }
        if let Some(init) = self.initial {
            if let Some(s) = init.sigma_dv {
                m.sigma_dv0 = s;
            }
            if let Some(s) = init.sigma_delta {
                m.sigma_delta0 = s;
            }
        }
        m.layout()
            .map_err(|e| anyhow!("model: {e:?} (dt, sigma_v, initial or state count)"))?;
        Ok(m)
    }

    /// From the core model.
    pub fn from_core(m: &InsModel<f64>) -> Self {
        Self {
            name: None,
            description: None,
            hours: None,
            dt: m.dt,
            observation: ObservationToml {
                sigma_v: m.sigma_v,
                colored: m
                    .colored
                    .iter()
                    .map(|g| ColoredToml {
                        kind: gm_kind(),
                        sigma: g.sigma,
                        tau: g.tau,
                    })
                    .collect(),
            },
            initial: Some(InitialToml {
                sigma_dv: Some(m.sigma_dv0),
                sigma_delta: Some(m.sigma_delta0),
            }),
            accel: m.accel.iter().map(ComponentToml::from_core).collect(),
            gyro: m.gyro.iter().map(ComponentToml::from_core).collect(),
        }
    }
}

/// Parses model TOML text; `origin` names the source in errors.
pub fn parse(text: &str, origin: &str) -> Result<InsModel<f64>> {
    parse_file(text, origin)?
        .to_core()
        .with_context(|| format!("{origin}: invalid model"))
}

/// Parses the TOML structure without converting it.
pub fn parse_file(text: &str, origin: &str) -> Result<ModelToml> {
    toml::from_str(text).map_err(|e| anyhow!("{origin}: {e}"))
}

/// Reads a model TOML file.
pub fn load(path: &Path) -> Result<InsModel<f64>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse(&text, &path.display().to_string())
}

/// Serialises a core model as TOML.
pub fn to_string(m: &InsModel<f64>) -> Result<String> {
    Ok(toml::to_string_pretty(&ModelToml::from_core(m))?)
}
