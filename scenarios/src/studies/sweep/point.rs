//! A grid point and its index: the axes' value indices, the last axis fastest.

/// One point of the grid: the value index on each axis.
pub type Point = Vec<usize>;

/// Point `index` of a grid whose axes hold `lens` values each: the value index on each axis,
/// the last axis fastest.
pub(super) fn point_of(index: usize, lens: &[usize]) -> Point {
    let mut rest = index;
    let mut point = vec![0; lens.len()];
    for (a, &len) in lens.iter().enumerate().rev() {
        let n = len.max(1);
        point[a] = rest % n;
        rest /= n;
    }
    point
}
