//! Datasheet units for the IMU's keys: a value is a number in the key's SI unit, as always, or
//! a string `"NUMBER UNIT"` in any unit of the key's dimension, converted to SI when the file
//! is read (so a file in datasheet units runs to the same bytes as its SI twin).
//!
//! ```toml
//! [rig.imu]
//! rate_hz = "200 Hz"
//! gyroscope_noise_density = "0.18 deg/sqrt(h)"     # angle random walk, as datasheets give it
//! accelerometer_noise_density = "175 ug/sqrt(Hz)"  # g is standard gravity, 9.80665 m/s²
//! gyroscope_random_walk = "0.002 deg/s^2/sqrt(Hz)"
//! accelerometer_random_walk = "0.03 mg/sqrt(s)"
//! gyro_range_rad_s = "2000 deg/s"
//! accel_range_m_s2 = "16 g"
//! ```
//!
//! A unit is a product of factors (`*`, `·` or a space) and quotients (`/`, left to right), each
//! factor a unit name, `sqrt(…)` or `√…`, or a parenthesized unit, raised by `^N` (whole or half
//! powers). Names: angles `rad`, `mrad`, `urad`, `deg` (`°`), angular rates `dps`, `mdps`,
//! lengths `m`, `cm`, `mm`, `um`, times `s`, `ms`, `us`, `ns`, `min`, `h` (`hr`), frequencies
//! `Hz`, `kHz`, and accelerations `g`, `mg`, `ug` (micro as `u`, `µ` or `μ`). The dimension is
//! checked against the key's, angles included (SI calls the radian dimensionless, a datasheet
//! does not), so `deg/h` where a density is expected is refused naming both. General unit
//! crates read `g` as the gram and drop the radian, the two things an IMU datasheet relies on,
//! hence this small table.

use std::f64::consts::PI;
use std::fmt;

use serde::Deserializer;
use serde::de::{self, Visitor};

/// Standard gravity (m/s²), the `g` of accelerometer datasheets (CGPM 1901).
pub const STANDARD_GRAVITY: f64 = 9.80665;

/// A dimension: exponents of angle, length and time, each doubled (so `√Hz` is a whole
/// number).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Dimension {
    angle: i32,
    length: i32,
    time: i32,
}

impl Dimension {
    /// From undoubled exponents.
    const fn new(angle: i32, length: i32, time: i32) -> Self {
        Self {
            angle: 2 * angle,
            length: 2 * length,
            time: 2 * time,
        }
    }

    /// From doubled exponents (a density carries √Hz, a half power of time).
    const fn doubled(angle: i32, length: i32, time: i32) -> Self {
        Self {
            angle,
            length,
            time,
        }
    }

    fn add(self, o: Self) -> Self {
        Self {
            angle: self.angle + o.angle,
            length: self.length + o.length,
            time: self.time + o.time,
        }
    }

    /// The power `halves / 2`; `None` where an exponent would not be a whole or half power.
    fn pow(self, halves: i32) -> Option<Self> {
        let p = |e: i32| (e * halves % 2 == 0).then_some(e * halves / 2);
        Some(Self {
            angle: p(self.angle)?,
            length: p(self.length)?,
            time: p(self.time)?,
        })
    }
}

impl fmt::Display for Dimension {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        for (name, e) in [
            ("angle", self.angle),
            ("length", self.length),
            ("time", self.time),
        ] {
            match e {
                0 => {}
                2 => parts.push(name.to_string()),
                e if e % 2 == 0 => parts.push(format!("{name}^{}", e / 2)),
                e => parts.push(format!("{name}^{}", f64::from(e) / 2.0)),
            }
        }
        if parts.is_empty() {
            write!(f, "a pure number")
        } else {
            write!(f, "{}", parts.join("·"))
        }
    }
}

/// What an IMU key measures: its dimension, its SI unit and a few datasheet units it accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// Sample rate (Hz).
    Frequency,
    /// Gyroscope white noise density (rad/s/√Hz; the angle random walk).
    GyroDensity,
    /// Accelerometer white noise density (m/s²/√Hz; the velocity random walk).
    AccelDensity,
    /// Gyroscope bias random walk (rad/s²/√Hz).
    GyroRandomWalk,
    /// Accelerometer bias random walk (m/s³/√Hz).
    AccelRandomWalk,
    /// Angular rate (rad/s).
    AngularRate,
    /// Acceleration (m/s²).
    Acceleration,
}

impl Quantity {
    fn dimension(self) -> Dimension {
        match self {
            Quantity::Frequency => Dimension::new(0, 0, -1),
            Quantity::GyroDensity => Dimension::doubled(2, 0, -1),
            Quantity::AccelDensity => Dimension::doubled(0, 2, -3),
            Quantity::GyroRandomWalk => Dimension::doubled(2, 0, -3),
            Quantity::AccelRandomWalk => Dimension::doubled(0, 2, -5),
            Quantity::AngularRate => Dimension::new(1, 0, -1),
            Quantity::Acceleration => Dimension::new(0, 1, -2),
        }
    }

    /// The SI unit a plain number is read in, and datasheet units the key accepts.
    pub fn units(self) -> (&'static str, &'static str) {
        match self {
            Quantity::Frequency => ("Hz", "kHz"),
            Quantity::GyroDensity => (
                "rad/s/sqrt(Hz)",
                "deg/sqrt(h), deg/s/sqrt(Hz), mdps/sqrt(Hz)",
            ),
            Quantity::AccelDensity => ("m/s^2/sqrt(Hz)", "ug/sqrt(Hz), mg/sqrt(Hz), m/s/sqrt(h)"),
            Quantity::GyroRandomWalk => ("rad/s^2/sqrt(Hz)", "deg/h/sqrt(h), deg/s^2/sqrt(Hz)"),
            Quantity::AccelRandomWalk => ("m/s^3/sqrt(Hz)", "mg/sqrt(s), m/s/h/sqrt(h)"),
            Quantity::AngularRate => ("rad/s", "deg/s, dps"),
            Quantity::Acceleration => ("m/s^2", "g, mg"),
        }
    }
}

/// `text` (`"NUMBER UNIT"`) as a value in `q`'s SI unit; the error says what was expected.
pub fn parse(text: &str, q: Quantity) -> Result<f64, String> {
    let (si, examples) = q.units();
    let t = text.trim();
    let split = number_end(t);
    let number: f64 = t[..split].parse().map_err(|_| {
        format!("`{text}`: expected a number and a unit (e.g. `1.0 {si}`, or {examples})")
    })?;
    let unit = t[split..].trim();
    if unit.is_empty() {
        return Err(format!(
            "`{text}`: a string needs a unit (a plain number is read in {si}; or {examples})"
        ));
    }
    let (scale, dim) = Parser::new(unit)
        .unit()
        .map_err(|m| format!("`{text}`: {m} (units in {si} or e.g. {examples})"))?;
    if dim != q.dimension() {
        return Err(format!(
            "`{text}`: `{unit}` is {dim}, this key wants {} ({si}; or {examples})",
            q.dimension()
        ));
    }
    let v = number * scale;
    if !v.is_finite() {
        return Err(format!("`{text}`: not a finite value in {si}"));
    }
    Ok(v)
}

/// Where a leading decimal number ends in `t`.
fn number_end(t: &str) -> usize {
    let b = t.as_bytes();
    let mut i = 0;
    if i < b.len() && (b[i] == b'+' || b[i] == b'-') {
        i += 1;
    }
    while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
        i += 1;
    }
    // An exponent only when digits follow it (`2e-3`, not the `e` of a unit).
    if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
        let mut j = i + 1;
        if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
            j += 1;
        }
        if j < b.len() && b[j].is_ascii_digit() {
            while j < b.len() && b[j].is_ascii_digit() {
                j += 1;
            }
            i = j;
        }
    }
    i
}

/// A named unit: its SI scale and dimension.
fn named(name: &str) -> Option<(f64, Dimension)> {
    let deg = PI / 180.0;
    let angle = Dimension::new(1, 0, 0);
    let length = Dimension::new(0, 1, 0);
    let time = Dimension::new(0, 0, 1);
    let rate = Dimension::new(1, 0, -1);
    let accel = Dimension::new(0, 1, -2);
    let name = name.replace(['µ', 'μ'], "u");
    Some(match name.as_str() {
        "rad" => (1.0, angle),
        "mrad" => (1e-3, angle),
        "urad" => (1e-6, angle),
        "deg" | "°" => (deg, angle),
        "dps" => (deg, rate),
        "mdps" => (1e-3 * deg, rate),
        "m" => (1.0, length),
        "cm" => (1e-2, length),
        "mm" => (1e-3, length),
        "um" => (1e-6, length),
        "s" | "sec" => (1.0, time),
        "ms" => (1e-3, time),
        "us" => (1e-6, time),
        "ns" => (1e-9, time),
        "min" => (60.0, time),
        "h" | "hr" => (3600.0, time),
        "Hz" | "hz" => (1.0, Dimension::new(0, 0, -1)),
        "kHz" | "khz" => (1e3, Dimension::new(0, 0, -1)),
        "g" => (STANDARD_GRAVITY, accel),
        "mg" => (1e-3 * STANDARD_GRAVITY, accel),
        "ug" => (1e-6 * STANDARD_GRAVITY, accel),
        _ => return None,
    })
}

/// A recursive-descent reader of one unit expression.
struct Parser<'a> {
    rest: &'a str,
}

impl<'a> Parser<'a> {
    fn new(s: &'a str) -> Self {
        Self { rest: s }
    }

    fn skip_space(&mut self) {
        self.rest = self.rest.trim_start();
    }

    fn eat(&mut self, prefix: &str) -> bool {
        self.skip_space();
        match self.rest.strip_prefix(prefix) {
            Some(r) => {
                self.rest = r;
                true
            }
            None => false,
        }
    }

    /// The whole text as one unit.
    fn unit(mut self) -> Result<(f64, Dimension), String> {
        let u = self.product()?;
        self.skip_space();
        if !self.rest.is_empty() {
            return Err(format!("cannot read `{}`", self.rest));
        }
        Ok(u)
    }

    /// factor (('*' | '·' | '/' | ' ') factor)*
    fn product(&mut self) -> Result<(f64, Dimension), String> {
        let (mut scale, mut dim) = self.power()?;
        loop {
            let divide = if self.eat("/") {
                true
            } else if self.eat("*") || self.eat("·") {
                false
            } else {
                self.skip_space();
                if self.rest.is_empty() || self.rest.starts_with(')') {
                    return Ok((scale, dim));
                }
                false
            };
            let (s, d) = self.power()?;
            if divide {
                scale /= s;
                dim = dim.add(d.pow(-2).expect("a whole power"));
            } else {
                scale *= s;
                dim = dim.add(d);
            }
        }
    }

    /// base ('^' exponent)?
    fn power(&mut self) -> Result<(f64, Dimension), String> {
        let (scale, dim) = self.base()?;
        if !self.eat("^") {
            return Ok((scale, dim));
        }
        self.skip_space();
        let paren = self.eat("(");
        self.skip_space();
        let end = number_end(self.rest);
        let p: f64 = self.rest[..end]
            .parse()
            .map_err(|_| format!("expected an exponent at `{}`", self.rest))?;
        self.rest = &self.rest[end..];
        if paren && !self.eat(")") {
            return Err("expected `)` after the exponent".into());
        }
        let halves = 2.0 * p;
        if halves.fract() != 0.0 || halves.abs() > 12.0 {
            return Err(format!("exponent {p}: whole or half powers up to 6 only"));
        }
        let halves = halves as i32;
        let dim = dim
            .pow(halves)
            .ok_or_else(|| format!("exponent {p} leaves a quarter power"))?;
        let scale = if halves % 2 == 0 {
            scale.powi(halves / 2)
        } else {
            scale.sqrt().powi(halves)
        };
        Ok((scale, dim))
    }

    /// 'sqrt(' product ')' | '√' base | '(' product ')' | name
    fn base(&mut self) -> Result<(f64, Dimension), String> {
        self.skip_space();
        let root = |(s, d): (f64, Dimension)| -> Result<(f64, Dimension), String> {
            let d = d.pow(1).ok_or("a square root leaves a quarter power")?;
            Ok((s.sqrt(), d))
        };
        if self.eat("sqrt(") {
            let u = self.product()?;
            if !self.eat(")") {
                return Err("expected `)` to close `sqrt(`".into());
            }
            return root(u);
        }
        if self.eat("√") {
            let u = self.base()?;
            return root(u);
        }
        if self.eat("(") {
            let u = self.product()?;
            if !self.eat(")") {
                return Err("expected `)`".into());
            }
            return Ok(u);
        }
        let end = self
            .rest
            .find(|c: char| !(c.is_alphabetic() || c == '°'))
            .unwrap_or(self.rest.len());
        let name = &self.rest[..end];
        if name.is_empty() {
            return Err(format!("expected a unit at `{}`", self.rest));
        }
        let u = named(name).ok_or_else(|| format!("unknown unit `{name}`"))?;
        self.rest = &self.rest[end..];
        Ok(u)
    }
}

/// A serde reader of a value of quantity `Q`: a number (SI) or a `"NUMBER UNIT"` string.
struct QuantityVisitor(Quantity);

impl Visitor<'_> for QuantityVisitor {
    type Value = f64;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (si, examples) = self.0.units();
        write!(f, "a number in {si} or a string with a unit ({examples})")
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<f64, E> {
        Ok(v)
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<f64, E> {
        Ok(v as f64)
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<f64, E> {
        Ok(v as f64)
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<f64, E> {
        parse(v, self.0).map_err(E::custom)
    }
}

macro_rules! quantity_fields {
    ($($(#[$doc:meta])* $name:ident, $opt:ident => $q:expr;)*) => {$(
        $(#[$doc])*
        pub fn $name<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
            d.deserialize_any(QuantityVisitor($q))
        }

        /// The optional form (use with `#[serde(default)]`).
        pub fn $opt<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
            struct OptionVisitor;
            impl<'de> Visitor<'de> for OptionVisitor {
                type Value = Option<f64>;
                fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                    QuantityVisitor($q).expecting(f)
                }
                fn visit_none<E: de::Error>(self) -> Result<Self::Value, E> {
                    Ok(None)
                }
                fn visit_some<D2: Deserializer<'de>>(self, d: D2) -> Result<Self::Value, D2::Error> {
                    $name(d).map(Some)
                }
            }
            d.deserialize_option(OptionVisitor)
        }
    )*};
}

quantity_fields! {
    /// A frequency (Hz).
    frequency, frequency_opt => Quantity::Frequency;
    /// A gyroscope noise density (rad/s/√Hz).
    gyro_density, gyro_density_opt => Quantity::GyroDensity;
    /// An accelerometer noise density (m/s²/√Hz).
    accel_density, accel_density_opt => Quantity::AccelDensity;
    /// A gyroscope bias random walk (rad/s²/√Hz).
    gyro_random_walk, gyro_random_walk_opt => Quantity::GyroRandomWalk;
    /// An accelerometer bias random walk (m/s³/√Hz).
    accel_random_walk, accel_random_walk_opt => Quantity::AccelRandomWalk;
    /// An angular rate (rad/s).
    angular_rate, angular_rate_opt => Quantity::AngularRate;
    /// An acceleration (m/s²).
    acceleration, acceleration_opt => Quantity::Acceleration;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * b.abs()
    }

    /// The datasheet forms of each IMU quantity, against conversions worked by hand.
    #[test]
    fn datasheet_units_convert_to_si() {
        let deg = PI / 180.0;
        let cases = [
            ("0.18 deg/sqrt(h)", Quantity::GyroDensity, 0.18 * deg / 60.0),
            ("0.18 °/√h", Quantity::GyroDensity, 0.18 * deg / 60.0),
            ("0.014 deg/s/sqrt(Hz)", Quantity::GyroDensity, 0.014 * deg),
            ("14 mdps/√Hz", Quantity::GyroDensity, 0.014 * deg),
            ("1.6968e-4 rad/s/sqrt(Hz)", Quantity::GyroDensity, 1.6968e-4),
            ("175 ug/sqrt(Hz)", Quantity::AccelDensity, 175e-6 * 9.80665),
            ("175 µg/√Hz", Quantity::AccelDensity, 175e-6 * 9.80665),
            ("0.11 m/s/sqrt(h)", Quantity::AccelDensity, 0.11 / 60.0),
            ("2e-3 m/s^2/sqrt(Hz)", Quantity::AccelDensity, 2e-3),
            (
                "2 deg/h/sqrt(h)",
                Quantity::GyroRandomWalk,
                2.0 * deg / 3600.0 / 60.0,
            ),
            (
                "2 deg/h^1.5",
                Quantity::GyroRandomWalk,
                2.0 * deg / 3600.0 / 60.0,
            ),
            (
                "0.03 mg/sqrt(s)",
                Quantity::AccelRandomWalk,
                0.03e-3 * 9.80665,
            ),
            ("2000 deg/s", Quantity::AngularRate, 2000.0 * deg),
            ("2000 dps", Quantity::AngularRate, 2000.0 * deg),
            ("16 g", Quantity::Acceleration, 16.0 * 9.80665),
            ("9.81 m/s^2", Quantity::Acceleration, 9.81),
            ("9.81 m*s^-2", Quantity::Acceleration, 9.81),
            ("200 Hz", Quantity::Frequency, 200.0),
            ("0.2kHz", Quantity::Frequency, 200.0),
        ];
        for (text, q, want) in cases {
            let got = parse(text, q).unwrap_or_else(|e| panic!("{text}: {e}"));
            assert!(close(got, want), "{text}: {got} against {want}");
        }
    }

    /// A unit of the wrong dimension, an unknown unit, a missing unit or number, and bad
    /// syntax are refused naming what was written and what the key wants.
    #[test]
    fn units_of_the_wrong_dimension_or_unknown_are_refused() {
        let cases = [
            (
                "0.18 deg/h",
                Quantity::GyroDensity,
                "this key wants angle·time^-0.5",
            ),
            ("175 ug", Quantity::AccelDensity, "`ug` is length·time^-2"),
            ("16 kg", Quantity::Acceleration, "unknown unit `kg`"),
            ("16", Quantity::Acceleration, "a string needs a unit"),
            (
                "fast Hz",
                Quantity::Frequency,
                "expected a number and a unit",
            ),
            ("1 deg/sqrt(h", Quantity::GyroDensity, "expected `)`"),
            (
                "1 deg/h^0.25",
                Quantity::GyroDensity,
                "whole or half powers",
            ),
            ("1 sqrt(sqrt(Hz))", Quantity::Frequency, "quarter power"),
            ("1e400 Hz", Quantity::Frequency, "not a finite value"),
        ];
        for (text, q, want) in cases {
            let e = parse(text, q).expect_err(text);
            assert!(e.contains(want), "{text}: {e}");
        }
    }
}
