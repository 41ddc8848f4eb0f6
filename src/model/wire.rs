//! A compact binary form of a model and its run options, written by the host and read by the
//! firmware (which has no TOML parser), so that the emulated board runs the model the user gave.
//!
//! # Format (version 1, little-endian)
//!
//! ```text
//! magic "IMUM" | version u16 = 1 | options u16 (bit 0: identify online)           8 bytes
//! dt, sigma_v, sigma_dv0, sigma_delta0: f64                                       32 bytes
//! n_accel u8 | n_gyro u8 | n_colored u8 | 0 u8                                      4 bytes
//! per accel then gyro component: kind u8 | a f64 | b f64 | c f64                  25 bytes each
//! per coloured component: tau f64 | sigma f64                                     16 bytes each
//! CRC-32 (as zlib) of everything before it                                          4 bytes
//! ```
//!
//! Component fields `a, b, c`: Gauss-Markov `sigma, tau, 0`; exponential-cosine
//! `sigma, tau, beta`; random walk `q, sigma0, 0`; random constant `sigma, 0, 0`; white `density, 0, 0`.
//! Kinds are coded as in the kind table, [`ComponentKind::code`].
//!
//! ```
//! use imu_ident::model::wire::{decode, encode, MAX_LEN};
//! use imu_ident::model::InsModel;
//! let mut buf = [0u8; MAX_LEN];
//! let n = encode(&InsModel::paper(), true, &mut buf).unwrap();
//! let (m, adapt) = decode::<f32>(&buf[..n]).unwrap();
//! assert!(adapt);
//! assert_eq!(m, InsModel::<f64>::paper().cast::<f32>());
//! ```

use super::ins::{MAX_COLORED, MAX_COMPONENTS};
use super::{Component, ComponentKind, GaussMarkov, InsModel};
use crate::crc::Crc32;
use crate::Real;

/// First four bytes.
pub const MAGIC: [u8; 4] = *b"IMUM";
/// Format version.
pub const VERSION: u16 = 1;
/// Option bit: identify the model online.
pub const OPT_ADAPT: u16 = 1;
/// Option bit (with [`OPT_ADAPT`]): the global stage on, as in
/// [`AdaptConfig::global`](crate::adapt::AdaptConfig::global).
pub const OPT_GLOBAL: u16 = 2;
/// Option bit (with [`OPT_GLOBAL`]): the global stage's structure test on
/// (`structure = STRUCTURE_PENALTY`, `docs/ADAPTATION.md` §7.6).
pub const OPT_STRUCTURE: u16 = 4;
const HEAD: usize = 8 + 32 + 4;
const COMP: usize = 25;
const COLORED: usize = 16;
/// Longest encoding (every component slot used).
pub const MAX_LEN: usize = HEAD + 2 * MAX_COMPONENTS * COMP + MAX_COLORED * COLORED + 4;

/// Why a model could not be encoded or decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WireError {
    /// The output buffer is too short.
    BufferTooSmall,
    /// Not a model file (magic).
    BadMagic,
    /// Unknown version.
    BadVersion,
    /// Unknown option bits, component kind or count.
    BadField,
    /// The data ends early or has bytes after the checksum.
    BadLength,
    /// The checksum does not match.
    BadChecksum,
}

struct Out<'a> {
    buf: &'a mut [u8],
    n: usize,
}

impl Out<'_> {
    fn put(&mut self, b: &[u8]) -> Result<(), WireError> {
        let end = self.n + b.len();
        let dst = self
            .buf
            .get_mut(self.n..end)
            .ok_or(WireError::BufferTooSmall)?;
        dst.copy_from_slice(b);
        self.n = end;
        Ok(())
    }
    fn f(&mut self, v: f64) -> Result<(), WireError> {
        self.put(&v.to_le_bytes())
    }
}

/// The kind code and the quantities of `c` in file order (the kind table), padded with zeros.
fn fields(c: &Component<f64>) -> (u8, [f64; 3]) {
    let kind = c.kind();
    let mut v = [0.0; 3];
    for (o, q) in v.iter_mut().zip(kind.quantities()) {
        *o = c.get(*q).unwrap_or(0.0);
    }
    (kind.code(), v)
}

/// Writes `model` with the option `adapt` into `out`; returns the number of bytes.
pub fn encode(model: &InsModel<f64>, adapt: bool, out: &mut [u8]) -> Result<usize, WireError> {
    encode_options(model, if adapt { OPT_ADAPT } else { 0 }, out)
}

/// Writes `model` with the option bits `options` (`OPT_*`) into `out`; returns the number of
/// bytes.
pub fn encode_options(
    model: &InsModel<f64>,
    options: u16,
    out: &mut [u8],
) -> Result<usize, WireError> {
    let mut o = Out { buf: out, n: 0 };
    o.put(&MAGIC)?;
    o.put(&VERSION.to_le_bytes())?;
    o.put(&options.to_le_bytes())?;
    for v in [model.dt, model.sigma_v, model.sigma_dv0, model.sigma_delta0] {
        o.f(v)?;
    }
    o.put(&[
        model.accel.len() as u8,
        model.gyro.len() as u8,
        model.colored.len() as u8,
        0,
    ])?;
    for c in model.accel.iter().chain(model.gyro.iter()) {
        let (k, v) = fields(c);
        o.put(&[k])?;
        for x in v {
            o.f(x)?;
        }
    }
    for g in &model.colored {
        o.f(g.tau)?;
        o.f(g.sigma)?;
    }
    let mut crc = Crc32::new();
    crc.update(o.buf.get(..o.n).ok_or(WireError::BufferTooSmall)?);
    o.put(&crc.value().to_le_bytes())?;
    Ok(o.n)
}

struct In<'a> {
    b: &'a [u8],
    n: usize,
}

impl In<'_> {
    fn take<const K: usize>(&mut self) -> Result<[u8; K], WireError> {
        let s = self.b.get(self.n..self.n + K).ok_or(WireError::BadLength)?;
        self.n += K;
        s.try_into().map_err(|_| WireError::BadLength)
    }
    fn u8(&mut self) -> Result<u8, WireError> {
        Ok(self.take::<1>()?[0])
    }
    fn f<T: Real>(&mut self) -> Result<T, WireError> {
        Ok(T::lit(f64::from_le_bytes(self.take::<8>()?)))
    }
}

fn component<T: Real>(kind: u8, a: T, b: T, c: T) -> Result<Component<T>, WireError> {
    let kind = ComponentKind::from_code(kind).ok_or(WireError::BadField)?;
    Ok(kind.with_quantities(&[a, b, c]))
}

/// Reads a model (in precision `T`) and its `adapt` option. Values are not validated here: the
/// filter does that when it is built from the model.
pub fn decode<T: Real>(bytes: &[u8]) -> Result<(InsModel<T>, bool), WireError> {
    decode_options(bytes).map(|(m, o)| (m, o & OPT_ADAPT != 0))
}

/// Reads a model (in precision `T`) and its option bits (`OPT_*`; unknown bits are an error).
pub fn decode_options<T: Real>(bytes: &[u8]) -> Result<(InsModel<T>, u16), WireError> {
    let body_len = bytes.len().checked_sub(4).ok_or(WireError::BadLength)?;
    let (body, crc) = bytes.split_at(body_len);
    let mut i = In { b: body, n: 0 };
    if i.take::<4>()? != MAGIC {
        return Err(WireError::BadMagic);
    }
    if u16::from_le_bytes(i.take::<2>()?) != VERSION {
        return Err(WireError::BadVersion);
    }
    let opts = u16::from_le_bytes(i.take::<2>()?);
    if opts & !(OPT_ADAPT | OPT_GLOBAL | OPT_STRUCTURE) != 0 {
        return Err(WireError::BadField);
    }
    let mut m = InsModel::empty(i.f()?, i.f()?);
    m.sigma_dv0 = i.f()?;
    m.sigma_delta0 = i.f()?;
    let [na, ng, nc, _] = i.take::<4>()?;
    for (count, gyro) in [(na, false), (ng, true)] {
        for _ in 0..count {
            let kind = i.u8()?;
            let c = component(kind, i.f()?, i.f()?, i.f()?)?;
            let list = if gyro { &mut m.gyro } else { &mut m.accel };
            list.push(c).map_err(|_| WireError::BadField)?;
        }
    }
    for _ in 0..nc {
        let g = GaussMarkov {
            tau: i.f()?,
            sigma: i.f()?,
        };
        m.colored.push(g).map_err(|_| WireError::BadField)?;
    }
    if i.n != body.len() {
        return Err(WireError::BadLength);
    }
    let mut c = Crc32::new();
    c.update(body);
    if crc != c.value().to_le_bytes() {
        return Err(WireError::BadChecksum);
    }
    Ok((m, opts))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ExpCosine, RandomConstant, RandomWalk, WhiteNoise};

    #[test]
    fn round_trip_with_every_kind_and_corruption_detected() {
        let mut m = InsModel::<f64>::paper();
        let _ = m.accel.push(Component::White(WhiteNoise { density: 1e-4 }));
        let _ = m.gyro.push(Component::ExpCosine(ExpCosine {
            sigma: 1e-6,
            tau: 300.0,
            beta: 0.01,
        }));
        let _ = m.gyro.push(Component::RandomWalk(RandomWalk {
            q: 1e-14,
            sigma0: 1e-5,
        }));
        let _ = m
            .gyro
            .push(Component::RandomConstant(RandomConstant { sigma: 1e-6 }));
        let _ = m.colored.push(GaussMarkov {
            sigma: 0.01,
            tau: 60.0,
        });
        let mut buf = [0u8; MAX_LEN];
        let n = encode(&m, false, &mut buf).unwrap();
        assert_eq!(decode::<f64>(&buf[..n]), Ok((m, false)));
        for i in 0..n {
            let mut b = buf;
            b[i] ^= 0x04;
            assert!(decode::<f64>(&b[..n]).is_err(), "byte {i}");
        }
        assert!(decode::<f64>(&buf[..n - 1]).is_err());
        assert_eq!(
            encode(&InsModel::paper(), false, &mut buf[..10]),
            Err(WireError::BufferTooSmall)
        );
    }

    /// Every known option bit survives the round trip; an unknown one is refused.
    #[test]
    fn option_bits_round_trip_and_unknown_bits_are_refused() {
        let mut buf = [0u8; MAX_LEN];
        let all = OPT_ADAPT | OPT_GLOBAL | OPT_STRUCTURE;
        let n = encode_options(&InsModel::<f64>::paper(), all, &mut buf).unwrap();
        assert_eq!(decode_options::<f64>(&buf[..n]).map(|(_, o)| o), Ok(all));
        let n = encode_options(&InsModel::<f64>::paper(), 8, &mut buf).unwrap_or(0);
        assert!(n == 0 || decode_options::<f64>(&buf[..n]).is_err());
    }
}
