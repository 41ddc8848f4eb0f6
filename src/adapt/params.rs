//! The identified parameter vector `theta` and its mapping to and from an [`InsModel`].
//!
//! Every identified quantity is a positive scale (a standard deviation, a correlation time, a
//! noise density), so `theta` holds their natural logarithms: a finite-difference step `h` is then
//! a relative perturbation `exp(h)`, the Fisher information is dimensionless, and a rate limit of
//! `ln 2` means "at most a factor two per update" whatever the units.
//!
//! Which quantities are identified follows from the model's component kinds (the kind table,
//! [`ComponentKind::identified`](crate::model::ComponentKind::identified)), accelerometer first,
//! then gyro, in component order, until [`MAXP`] parameters are taken.

use crate::model::{Component, ComponentKind, ErrorSource, InsModel, Quantity, IDENTIFIABLE_SD};
use crate::Real;
use heapless::Vec;

/// Largest number of identified parameters (the bank runs `2 p + 1` of its `2 MAXP + 1`
/// filters). Five: the paper's two Gauss-Markov components with one of them switched to a
/// three-parameter exponential-cosine (issue 13). Each unit costs two filters in the bank, two
/// in the global stage's pass and a row and column of every `MAXP`-sized array: 3.8-4.0 KB of
/// `.bss` in `f32`, measured (4 -> 5: +4 024 B; 5 -> 8: +11 520 B). Eight do not fit the
/// 64 KiB the firmware is held to (75 924 B with the stack, `BENCHMARKS.md`). The feature
/// `params8` raises it to eight (two components per sensor, each sensor's searched on its own
/// grid: `window` docs), to measure the cost law at p = 8 (`docs/ADAPTATION.md` §7.4); the
/// firmware's RAM bar is for five.
#[cfg(not(feature = "params8"))]
pub const MAXP: usize = 5;
/// Largest number of identified parameters, raised by the feature `params8` (see above).
#[cfg(feature = "params8")]
pub const MAXP: usize = 8;

/// One identified parameter: which component of which sensor, and which of its quantities.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ParamSpec {
    /// The error source the component belongs to.
    pub sensor: ErrorSource,
    /// The component's index in that sensor's list.
    pub index: u8,
    /// The quantity.
    pub kind: Quantity,
}

/// Where a structure switch happens and to which kind: the component of `sensor` at `index`
/// becomes a `kind` ([`window::structure`](crate::adapt::window::structure)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Site {
    /// The error source of the component.
    pub sensor: ErrorSource,
    /// Its index in that sensor's list.
    pub index: u8,
    /// The kind it becomes.
    pub kind: ComponentKind,
}

impl Site {
    /// A placeholder (all-zero bits: statics stay in `.bss`).
    pub const BLANK: Self = Self {
        sensor: ErrorSource::Accel,
        index: 0,
        kind: ComponentKind::GaussMarkov,
    };
}

impl ParamSpec {
    /// Whether `other` is a quantity of the same component (same sensor, same index).
    pub fn same_component(&self, other: &Self) -> bool {
        self.sensor == other.sensor && self.index == other.index
    }
}

/// The list of identified parameters of a model.
pub type Specs = Vec<ParamSpec, MAXP>;

/// The specs of every identifiable quantity of `model`, in `theta` order (at most [`MAXP`]).
pub fn specs<T: Real>(model: &InsModel<T>) -> Specs {
    let mut out = Specs::new();
    let sensors = [
        (ErrorSource::Accel, &model.accel),
        (ErrorSource::Gyro, &model.gyro),
    ];
    for (sensor, comps) in sensors {
        for (i, c) in comps.iter().enumerate() {
            let kinds = c.kind().identified();
            for &kind in kinds {
                let index = u8::try_from(i).unwrap_or(u8::MAX);
                // A full list simply stops taking parameters: the rest stay fixed.
                let _ = out.push(ParamSpec {
                    sensor,
                    index,
                    kind,
                });
            }
        }
    }
    out
}

fn component_mut<'a, T>(
    model: &'a mut InsModel<T>,
    spec: &ParamSpec,
) -> Option<&'a mut Component<T>> {
    let i = usize::from(spec.index);
    match spec.sensor {
        ErrorSource::Accel => model.accel.get_mut(i),
        ErrorSource::Gyro => model.gyro.get_mut(i),
        ErrorSource::Observation => None,
    }
}

/// The physical value (not its logarithm) of one parameter in `model`.
pub fn value<T: Real>(model: &InsModel<T>, spec: &ParamSpec) -> Option<T> {
    let i = usize::from(spec.index);
    let c = match spec.sensor {
        ErrorSource::Accel => model.accel.get(i),
        ErrorSource::Gyro => model.gyro.get(i),
        ErrorSource::Observation => None,
    }?;
    c.get(spec.kind)
}

/// `theta` of `model` for `specs` (natural logarithms; unused entries zero).
pub fn theta_of<T: Real>(model: &InsModel<T>, specs: &Specs) -> [T; MAXP] {
    let mut th = [T::zero(); MAXP];
    for (t, s) in th.iter_mut().zip(specs.iter()) {
        *t = value(model, s).map_or(T::zero(), |v| v.ln());
    }
    th
}

/// Writes `exp(theta)` into a copy of `base`. Returns `None` if a spec does not match the
/// model (the layout changed) or a value is not finite.
pub fn apply<T: Real>(base: &InsModel<T>, specs: &Specs, theta: &[T; MAXP]) -> Option<InsModel<T>> {
    let mut m = base.clone();
    for (s, &t) in specs.iter().zip(theta.iter()) {
        let v = t.exp();
        if !(v.is_finite() && v > T::zero()) {
            return None;
        }
        let c = component_mut(&mut m, s)?;
        if !c.set(s.kind, v) {
            return None;
        }
    }
    Some(m)
}

/// The entries of `values` (laid out as `from`) rearranged as `to`: a parameter present in both
/// (same sensor, component and quantity) keeps its value, the others take `fill`'s entry. Used
/// when a component changes kind (the structure switch of the global stage).
pub fn remap<T: Real>(from: &Specs, values: &[T; MAXP], to: &Specs, fill: &[T; MAXP]) -> [T; MAXP] {
    let mut out = *fill;
    for (o, s) in out.iter_mut().zip(to.iter()) {
        if let Some(k) = from.iter().position(|f| f == s) {
            if let Some(v) = values.get(k) {
                *o = *v;
            }
        }
    }
    out
}

/// Bit `i` of a mask of `theta` coordinates (at most 8; `0` beyond: no shift can overflow).
pub const fn coordinate_bit(i: usize) -> u8 {
    if i < 8 {
        1 << (i & 7)
    } else {
        0
    }
}

/// The coordinates (bit `i`: `theta[i]`) of the first `p` whose Cramér-Rao standard deviation
/// `sd` (`ln` units) is above [`IDENTIFIABLE_SD`] decades, or all of them when there is none
/// (the information is not positive definite): "not identifiable from these data yet" (issue 13,
/// item 2).
pub fn flat_coordinates<T: Real>(sd: Option<&[T; MAXP]>, p: usize) -> u8 {
    let p = p.min(MAXP);
    let Some(sd) = sd else {
        return (0..p).fold(0u8, |m, i| m | coordinate_bit(i));
    };
    let limit = T::lit(IDENTIFIABLE_SD * core::f64::consts::LN_10);
    let mut mask = 0u8;
    for (i, s) in sd.iter().enumerate().take(p) {
        // False for a NaN deviation: flat too.
        let identified = *s <= limit;
        if !identified {
            mask |= coordinate_bit(i);
        }
    }
    mask
}

/// Whether `mask` holds coordinate `i` ([`coordinate_bit`]).
pub const fn has_coordinate(mask: u8, i: usize) -> bool {
    mask & coordinate_bit(i) != 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_has_four_parameters_and_round_trips() {
        let m = InsModel::<f64>::paper();
        let s = specs(&m);
        assert_eq!(s.len(), 4);
        assert_eq!(s[1].kind, Quantity::Tau);
        assert_eq!(s[2].sensor, ErrorSource::Gyro);
        let th = theta_of(&m, &s);
        assert!((th[1] - 100f64.ln()).abs() < 1e-12);
        let back = apply(&m, &s, &th).unwrap();
        assert!((value(&back, &s[3]).unwrap() - 1200.0).abs() < 1e-9);
    }
}
