//! Fixed-length arrays that reject a wrong number of elements: serde's own array impls leave
//! extra elements unread, and TOML then accepts `resolution = [752, 480, 3]` silently.

use serde::de::Error;

use serde::{Deserialize, Deserializer};

fn to_array<T, const N: usize, E: Error>(v: Vec<T>) -> Result<[T; N], E> {
    let n = v.len();
    v.try_into()
        .map_err(|_| E::invalid_length(n, &format!("an array of {N} elements").as_str()))
}

/// `[T; N]`.
pub fn array<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    to_array(Vec::<T>::deserialize(d)?)
}

/// `Option<[T; N]>` (use with `#[serde(default)]`).
pub fn option<'de, D, T, const N: usize>(d: D) -> Result<Option<[T; N]>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    Option::<Vec<T>>::deserialize(d)?.map(to_array).transpose()
}

/// `Option<[[f64; 3]; 3]>` (a rotation matrix by rows; use with `#[serde(default)]`).
pub fn matrix<'de, D>(d: D) -> Result<Option<[[f64; 3]; 3]>, D::Error>
where
    D: Deserializer<'de>,
{
    let Some(rows) = Option::<Vec<Vec<f64>>>::deserialize(d)? else {
        return Ok(None);
    };
    let rows = rows
        .into_iter()
        .map(to_array::<f64, 3, D::Error>)
        .collect::<Result<Vec<_>, _>>()?;
    to_array(rows).map(Some)
}
