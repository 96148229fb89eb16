//! Exact geometric predicates (Shewchuk's adaptive arithmetic through `robust`) and the
//! symbolic perturbation that resolves cospherical and cocircular ties.
//!
//! Sign conventions used throughout the crate:
//! - [`orient`]`(a, b, c, d) > 0` when `det[b−a, c−a, d−a] > 0`, i.e. `d` lies on the side of the
//!   plane `abc` from which `a, b, c` appear counter-clockwise (a right-handed tetrahedron).
//!   This is the negation of Shewchuk's `orient3d`.
//! - [`in_sphere`]`(a, b, c, d, e) > 0` when `e` lies strictly inside the sphere through a
//!   positively oriented `a, b, c, d`.
//!
//! The perturbation is the one of Devillers & Teillaud ("Perturbations for Delaunay and weighted
//! Delaunay 3D triangulations", CGEOM 2011) as CGAL implements it: points are ranked
//! lexicographically by coordinates and the point of highest rank is lifted the most. Every
//! tie then has a consistent answer that does not depend on insertion order, so the result is
//! the unique Delaunay tetrahedralization of the perturbed set, which is a Delaunay
//! tetrahedralization of the original one.

use robust::{Coord, Coord3D};

/// A point in exact-predicate form (f32 input converted to f64 without rounding).
pub(crate) type P3 = [f64; 3];

#[inline]
fn c3(p: &P3) -> Coord3D<f64> {
    Coord3D {
        x: p[0],
        y: p[1],
        z: p[2],
    }
}

/// Sign of `det[b−a, c−a, d−a]`: +1, 0 or −1, exact.
#[inline]
pub(crate) fn orient(a: &P3, b: &P3, c: &P3, d: &P3) -> i32 {
    let s = robust::orient3d(c3(a), c3(b), c3(c), c3(d));
    if s < 0.0 {
        1
    } else if s > 0.0 {
        -1
    } else {
        0
    }
}

/// +1 if `e` is strictly inside the sphere through the positively oriented `a, b, c, d`,
/// −1 if strictly outside, 0 if on it. Exact.
#[inline]
pub(crate) fn in_sphere(a: &P3, b: &P3, c: &P3, d: &P3, e: &P3) -> i32 {
    if let Some(s) = in_sphere_filtered(a, b, c, d, e) {
        return s;
    }
    if let Some(s) = in_sphere_integer(a, b, c, d, e) {
        return s;
    }
    // Shewchuk's insphere expects his positive orientation, which is our negative one.
    let s = robust::insphere(c3(a), c3(b), c3(c), c3(d), c3(e));
    if s < 0.0 {
        1
    } else if s > 0.0 {
        -1
    } else {
        0
    }
}

/// A semi-static floating-point filter for [`in_sphere`] (as CGAL's static filters): the
/// determinant in plain f64, accepted when it exceeds a bound on its rounding error derived
/// from the largest coordinate differences; `None` sends the case to the exact predicate.
///
/// The determinant is Shewchuk's (2×2 minors, then 3×3, then the lifted 4×4), whose rounding
/// error is below `(16 + 224ε)ε` times its permanent (his `isperrboundA`); the permanent is at
/// most `72 · m⁵` with `m` the largest absolute coordinate difference, so `3e-13 · m⁵` bounds
/// the error with margin.
/// f32 inputs can neither overflow nor underflow this bound in f64.
#[inline]
fn in_sphere_filtered(a: &P3, b: &P3, c: &P3, d: &P3, e: &P3) -> Option<i32> {
    let aex = a[0] - e[0];
    let bex = b[0] - e[0];
    let cex = c[0] - e[0];
    let dex = d[0] - e[0];
    let aey = a[1] - e[1];
    let bey = b[1] - e[1];
    let cey = c[1] - e[1];
    let dey = d[1] - e[1];
    let aez = a[2] - e[2];
    let bez = b[2] - e[2];
    let cez = c[2] - e[2];
    let dez = d[2] - e[2];
    let ab = aex * bey - bex * aey;
    let bc = bex * cey - cex * bey;
    let cd = cex * dey - dex * cey;
    let da = dex * aey - aex * dey;
    let ac = aex * cey - cex * aey;
    let bd = bex * dey - dex * bey;
    let abc = aez * bc - bez * ac + cez * ab;
    let bcd = bez * cd - cez * bd + dez * bc;
    let cda = cez * da + dez * ac + aez * cd;
    let dab = dez * ab + aez * bd + bez * da;
    let alift = aex * aex + aey * aey + aez * aez;
    let blift = bex * bex + bey * bey + bez * bez;
    let clift = cex * cex + cey * cey + cez * cez;
    let dlift = dex * dex + dey * dey + dez * dez;
    // Shewchuk's insphere determinant (positive inside for his orientation, ours negated).
    let det = (dlift * abc - clift * dab) + (blift * cda - alift * bcd);
    // max() that compiles to one instruction (inputs are never NaN: finite f32 differences).
    let mx = |a: f64, b: f64| if a > b { a } else { b };
    let m = mx(
        mx(
            mx(mx(aex.abs(), bex.abs()), mx(cex.abs(), dex.abs())),
            mx(mx(aey.abs(), bey.abs()), mx(cey.abs(), dey.abs())),
        ),
        mx(mx(aez.abs(), bez.abs()), mx(cez.abs(), dez.abs())),
    );
    let m2 = m * m;
    let bound = 3e-13 * m2 * m2 * m;
    if det > bound {
        Some(-1)
    } else if det < -bound {
        Some(1)
    } else {
        None
    }
}

/// Exact in-sphere sign in integer arithmetic, for the near-degenerate cases the filter
/// cannot decide (every cospherical quintuple of a regular grid). Each f32-born coordinate is
/// `m · 2^q` with a 24-bit `m`; over the common scale `2^min q` the coordinates are integers.
/// When every difference to `e` is below L = 2^24 in magnitude, 2×2 minors are below 2L²
/// (i64), 3×3 ones below 6L³, lifts below 3L², and the determinant below 72·L⁵ < 2^127: it is
/// evaluated exactly in `i128`. `None` when the scale or span is too wide.
fn in_sphere_integer(a: &P3, b: &P3, c: &P3, d: &P3, e: &P3) -> Option<i32> {
    const LIMIT: i64 = 1 << 24;
    let pts = [a, b, c, d, e];
    let mut mant = [[0i64; 3]; 5];
    let mut expo = [[0i32; 3]; 5];
    let mut qmin = i32::MAX;
    for (k, p) in pts.iter().enumerate() {
        for axis in 0..3 {
            let v = p[axis];
            if v == 0.0 {
                continue;
            }
            let bits = v.to_bits();
            let biased = ((bits >> 52) & 0x7ff) as i32;
            if biased == 0 || biased == 0x7ff {
                return None;
            }
            let full = (bits & ((1u64 << 52) - 1)) | (1u64 << 52);
            let tz = full.trailing_zeros();
            let m = (full >> tz) as i64;
            if m >= 1 << 24 {
                return None; // not an f32 value
            }
            let q = biased - 1075 + tz as i32;
            mant[k][axis] = if v < 0.0 { -m } else { m };
            expo[k][axis] = q;
            qmin = qmin.min(q);
        }
    }
    let mut int = [[0i64; 3]; 5];
    for k in 0..5 {
        for axis in 0..3 {
            if mant[k][axis] != 0 {
                let shift = expo[k][axis] - qmin;
                if shift > 38 {
                    return None;
                }
                int[k][axis] = mant[k][axis] << shift;
            }
        }
    }
    let mut diff = [[0i64; 3]; 4];
    for k in 0..4 {
        for axis in 0..3 {
            let x = int[k][axis] - int[4][axis];
            if x.abs() >= LIMIT {
                return None;
            }
            diff[k][axis] = x;
        }
    }
    let [
        [aex, aey, aez],
        [bex, bey, bez],
        [cex, cey, cez],
        [dex, dey, dez],
    ] = diff;
    let ab = aex * bey - bex * aey;
    let bc = bex * cey - cex * bey;
    let cd = cex * dey - dex * cey;
    let da = dex * aey - aex * dey;
    let ac = aex * cey - cex * aey;
    let bd = bex * dey - dex * bey;
    let w = |x: i64| x as i128;
    let abc = w(aez) * w(bc) - w(bez) * w(ac) + w(cez) * w(ab);
    let bcd = w(bez) * w(cd) - w(cez) * w(bd) + w(dez) * w(bc);
    let cda = w(cez) * w(da) + w(dez) * w(ac) + w(aez) * w(cd);
    let dab = w(dez) * w(ab) + w(aez) * w(bd) + w(bez) * w(da);
    let alift = w(aex * aex + aey * aey + aez * aez);
    let blift = w(bex * bex + bey * bey + bez * bez);
    let clift = w(cex * cex + cey * cey + cez * cez);
    let dlift = w(dex * dex + dey * dey + dez * dez);
    let det = (dlift * abc - clift * dab) + (blift * cda - alift * bcd);
    Some(match det.cmp(&0) {
        std::cmp::Ordering::Greater => -1,
        std::cmp::Ordering::Less => 1,
        std::cmp::Ordering::Equal => 0,
    })
}

/// Sign of the 2-D orientation of `a, b, c` projected by dropping coordinate `drop`.
#[inline]
fn orient_projected(a: &P3, b: &P3, c: &P3, drop: usize) -> i32 {
    let (i, j) = match drop {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    };
    let s = robust::orient2d(
        Coord { x: a[i], y: a[j] },
        Coord { x: b[i], y: b[j] },
        Coord { x: c[i], y: c[j] },
    );
    if s > 0.0 {
        1
    } else if s < 0.0 {
        -1
    } else {
        0
    }
}

/// The coordinate to drop so that the plane through `a, b, c` projects one-to-one, or `None`
/// if the three points are collinear (exact).
#[inline]
pub(crate) fn projection_axis(a: &P3, b: &P3, c: &P3) -> Option<usize> {
    (0..3).find(|&axis| orient_projected(a, b, c, axis) != 0)
}

/// Whether three points are collinear (exact).
#[inline]
pub(crate) fn collinear(a: &P3, b: &P3, c: &P3) -> bool {
    projection_axis(a, b, c).is_none()
}

/// Lexicographic order of points (x, then y, then z): the perturbation's ranking.
#[inline]
fn lex_less(a: &P3, b: &P3) -> bool {
    a < b
}

/// Sorts up to five point references by the perturbation order (insertion sort, tiny inputs).
#[inline]
fn sort_lex<const N: usize>(pts: &mut [&P3; N]) {
    for i in 1..N {
        let mut j = i;
        while j > 0 && lex_less(pts[j], pts[j - 1]) {
            pts.swap(j, j - 1);
            j -= 1;
        }
    }
}

/// Perturbed in-sphere test for a positively oriented finite tetrahedron: +1 if `p` is in
/// conflict (inside the perturbed sphere), −1 otherwise. Never 0 for distinct points.
pub(crate) fn sphere_conflict(p0: &P3, p1: &P3, p2: &P3, p3: &P3, p: &P3) -> i32 {
    let s = in_sphere(p0, p1, p2, p3, p);
    if s != 0 {
        return s;
    }
    let mut sorted = [p0, p1, p2, p3, p];
    sort_lex(&mut sorted);
    // The two highest-ranked points decide (Devillers & Teillaud, Section 3).
    for q in [sorted[4], sorted[3]] {
        if std::ptr::eq(q, p) {
            return -1;
        }
        let o = if std::ptr::eq(q, p3) {
            orient(p0, p1, p2, p)
        } else if std::ptr::eq(q, p2) {
            orient(p0, p1, p, p3)
        } else if std::ptr::eq(q, p1) {
            orient(p0, p, p2, p3)
        } else {
            orient(p, p1, p2, p3)
        };
        if o != 0 {
            return o;
        }
    }
    // Unreachable for a non-degenerate tetrahedron and distinct points; answer "no conflict",
    // which keeps the cavity star-shaped.
    -1
}

/// Exact in-circle test for four coplanar points (`p0, p1, p2` not collinear): +1 if `p` is
/// strictly inside the circle through `p0, p1, p2`, −1 if outside, 0 if on it.
///
/// The circle is the intersection of the plane with the sphere through `p0, p1, p2` and a
/// fourth point lifted off the plane along a coordinate axis; the in-sphere test on that
/// sphere is exact and agrees with the in-circle test for points of the plane.
fn in_circle_coplanar(p0: &P3, p1: &P3, p2: &P3, p: &P3, axis: usize) -> i32 {
    let mut lifted = *p0;
    // |offset| > |p0[axis]|, so the rounded sum differs from p0[axis] and the lifted point is
    // off the plane (the plane's normal has a non-zero `axis` component).
    lifted[axis] = p0[axis] + (1.0 + p0[axis].abs());
    let o = orient(p0, p1, p2, &lifted);
    debug_assert!(o != 0);
    if o > 0 {
        in_sphere(p0, p1, p2, &lifted, p)
    } else {
        in_sphere(p1, p0, p2, &lifted, p)
    }
}

/// Perturbed conflict test between point `p` and the ghost (infinite) tetrahedron whose finite
/// face is `p0, p1, p2`, ordered so that replacing the infinite vertex by a point beyond the
/// hull gives a positive orientation. +1 conflict, −1 none.
pub(crate) fn ghost_conflict(p0: &P3, p1: &P3, p2: &P3, p: &P3) -> i32 {
    let o = orient(p0, p1, p2, p);
    if o != 0 {
        return o;
    }
    let Some(axis) = projection_axis(p0, p1, p2) else {
        return -1;
    };
    let bs = in_circle_coplanar(p0, p1, p2, p, axis);
    if bs != 0 {
        return bs;
    }
    let mut sorted = [p0, p1, p2, p];
    sort_lex(&mut sorted);
    let local = orient_projected(p0, p1, p2, axis);
    for q in [sorted[3], sorted[2], sorted[1]] {
        if std::ptr::eq(q, p) {
            return -1;
        }
        let o = if std::ptr::eq(q, p2) {
            orient_projected(p0, p1, p, axis)
        } else if std::ptr::eq(q, p1) {
            orient_projected(p0, p, p2, axis)
        } else {
            orient_projected(p, p1, p2, axis)
        };
        if o != 0 {
            return o * local;
        }
    }
    -1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orientation_sign_is_right_handed() {
        let a = [0.0, 0.0, 0.0];
        let b = [1.0, 0.0, 0.0];
        let c = [0.0, 1.0, 0.0];
        let d = [0.0, 0.0, 1.0];
        assert_eq!(orient(&a, &b, &c, &d), 1);
        assert_eq!(orient(&b, &a, &c, &d), -1);
        assert_eq!(orient(&a, &b, &c, &[0.5, 0.5, 0.0]), 0);
    }

    #[test]
    fn in_sphere_sign_is_positive_inside() {
        let a = [0.0, 0.0, 0.0];
        let b = [1.0, 0.0, 0.0];
        let c = [0.0, 1.0, 0.0];
        let d = [0.0, 0.0, 1.0];
        assert_eq!(in_sphere(&a, &b, &c, &d, &[0.25, 0.25, 0.25]), 1);
        assert_eq!(in_sphere(&a, &b, &c, &d, &[2.0, 2.0, 2.0]), -1);
        // The cube corner (1,1,1) is on the sphere through the other corners.
        assert_eq!(in_sphere(&a, &b, &c, &d, &[1.0, 1.0, 1.0]), 0);
    }

    #[test]
    fn filter_agrees_with_the_exact_predicate() {
        let mut rng = crate::rng::SplitMix64::new(17);
        let mut r = |scale: f32| (rng.unit_f32() * 2.0 - 1.0) * scale;
        let mut decided = 0;
        for i in 0..20_000 {
            let scale = [1e-6f32, 1.0, 1e3, 3e7][i % 4];
            let mut p: Vec<P3> = (0..5)
                .map(|_| [r(scale) as f64, r(scale) as f64, r(scale) as f64])
                .collect();
            if i % 3 == 0 {
                // Nearly cospherical: e close to a's mirror through the centre... keep it simple:
                // put e very near a, where the determinant is tiny.
                p[4] = [p[0][0] + 1e-30, p[0][1], p[0][2]];
            }
            if orient(&p[0], &p[1], &p[2], &p[3]) < 0 {
                p.swap(0, 1);
            }
            let exact = {
                let s = robust::insphere(c3(&p[0]), c3(&p[1]), c3(&p[2]), c3(&p[3]), c3(&p[4]));
                if s < 0.0 {
                    1
                } else if s > 0.0 {
                    -1
                } else {
                    0
                }
            };
            if let Some(f) = in_sphere_filtered(&p[0], &p[1], &p[2], &p[3], &p[4]) {
                assert_eq!(f, exact, "case {i}");
                decided += 1;
            }
            assert_eq!(in_sphere(&p[0], &p[1], &p[2], &p[3], &p[4]), exact);
        }
        assert!(decided > 10_000, "the filter decided only {decided} cases");
    }

    #[test]
    fn integer_path_agrees_with_the_exact_predicate() {
        let mut rng = crate::rng::SplitMix64::new(23);
        let mut decided = 0;
        for i in 0..20_000 {
            // Lattice points (scaled by awkward f32 steps), often cospherical.
            let step = [1.0f32, 0.37, 0.1, 1e-3, 1e-7][i % 5];
            let offset = [0.0f32, 5.3, -120.7, 0.0, 3.0e-6][i % 5];
            let mut p: Vec<P3> = (0..5)
                .map(|_| {
                    let mut q = [0.0f64; 3];
                    for v in &mut q {
                        *v = (offset + step * (rng.below(7) as f32)) as f64;
                    }
                    q
                })
                .collect();
            let o = orient(&p[0], &p[1], &p[2], &p[3]);
            if o == 0 {
                continue;
            }
            if o < 0 {
                p.swap(0, 1);
            }
            let s = robust::insphere(c3(&p[0]), c3(&p[1]), c3(&p[2]), c3(&p[3]), c3(&p[4]));
            let exact = if s < 0.0 {
                1
            } else if s > 0.0 {
                -1
            } else {
                0
            };
            if let Some(v) = in_sphere_integer(&p[0], &p[1], &p[2], &p[3], &p[4]) {
                assert_eq!(v, exact, "case {i}: {p:?}");
                decided += 1;
            }
        }
        assert!(decided > 10_000, "integer path decided only {decided}");
    }

    #[test]
    fn perturbation_never_ties_on_cube_corners() {
        let corners: Vec<P3> = (0..8)
            .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
            .collect();
        let (a, b, c, d) = (&corners[0], &corners[1], &corners[2], &corners[4]);
        for e in &corners[3..] {
            if std::ptr::eq(e, d) {
                continue;
            }
            let s = sphere_conflict(a, b, c, d, e);
            assert!(s == 1 || s == -1);
        }
    }

    #[test]
    fn coplanar_circle_test_matches_geometry() {
        // Plane x + y + z = 3 through three axis points; test points on it.
        let p0 = [3.0, 0.0, 0.0];
        let p1 = [0.0, 3.0, 0.0];
        let p2 = [0.0, 0.0, 3.0];
        let axis = projection_axis(&p0, &p1, &p2).unwrap();
        assert_eq!(in_circle_coplanar(&p0, &p1, &p2, &[1.0, 1.0, 1.0], axis), 1);
        assert_eq!(
            in_circle_coplanar(&p0, &p1, &p2, &[5.0, 5.0, -7.0], axis),
            -1
        );
        // The circumcentre is (1,1,1) with radius sqrt(6); (2,2,-1) = centre + (1,1,-2) is on it.
        assert_eq!(
            in_circle_coplanar(&p0, &p1, &p2, &[2.0, 2.0, -1.0], axis),
            0
        );
    }
}
