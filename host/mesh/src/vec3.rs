//! The one set of small vector operations on [`Vec3`] (`[f64; 3]`, metres,
//! station frame) that every crate uses.
//!
//! Why free functions on an array and not a vector type: a mesh's vertices
//! are `Vec<[f64; 3]>` everywhere (files, the model's flat vectors, the
//! station's store), and these few operations are all the geometry code
//! needs. Each is written out component by component, in a fixed order, so
//! results are bit-for-bit the same wherever they are used (the analytic
//! tests of `tapeshape-measure` and `tapeshape-body` depend on it); nalgebra
//! stays where a crate does linear algebra on matrices.

use crate::Vec3;

/// `a + b`.
#[inline]
pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a - b`.
#[inline]
pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `s a`.
#[inline]
pub fn scale(a: Vec3, s: f64) -> Vec3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// Dot product `a . b` (`(a0 b0 + a1 b1) + a2 b2`).
#[inline]
pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Cross product `a x b` (right-handed).
#[inline]
pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Euclidean length `|a|`.
#[inline]
pub fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

/// Distance `|a - b|` between two points.
#[inline]
pub fn distance(a: Vec3, b: Vec3) -> f64 {
    norm(sub(a, b))
}

/// `a / |a|` (each component divided by the length), or zero for a zero
/// vector.
#[inline]
pub fn normalize(a: Vec3) -> Vec3 {
    let n = norm(a);
    if n > 0.0 {
        [a[0] / n, a[1] / n, a[2] / n]
    } else {
        [0.0; 3]
    }
}

/// The (unnormalised) normal `(b - a) x (c - a)` of triangle `a, b, c`:
/// its length is twice the triangle's area, its direction follows the
/// winding (counter-clockwise seen from where it points).
#[inline]
pub fn triangle_normal(a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    cross(sub(b, a), sub(c, a))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn operations_on_the_axes() {
        let (x, y, z) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
        assert_eq!(cross(x, y), z);
        assert_eq!(cross(y, z), x);
        assert_eq!(dot(x, y), 0.0);
        assert_eq!(add(x, scale(y, 2.0)), [1.0, 2.0, 0.0]);
        assert_eq!(sub(z, x), [-1.0, 0.0, 1.0]);
        assert_eq!(norm([3.0, 4.0, 12.0]), 13.0);
        assert_eq!(distance([1.0, 1.0, 1.0], [4.0, 5.0, 13.0]), 13.0);
        assert_eq!(normalize([0.0, 0.0, -2.0]), [0.0, 0.0, -1.0]);
        assert_eq!(normalize([0.0; 3]), [0.0; 3]);
        // Counter-clockwise in the XY plane seen from +Z: normal +Z, length
        // twice the area (1/2).
        assert_eq!(triangle_normal([0.0; 3], x, y), z);
    }
}
