//! Interpolation on a rectilinear grid and the local map projection of geographic grids
//! (beyond the paper, whose fields are formulas: a gridded field from a file needs both).
//!
//! - [`quadratic_slope`]: the derivative at a node of the quadratic through three nodes.
//! - [`hermite`]: the cubic Hermite basis on one cell, with its first and second derivatives.
//!   A cubic Hermite interpolant whose node slopes come from [`quadratic_slope`] is C¹,
//!   reproduces every quadratic exactly, and its tensor product over axes is a C¹ surface
//!   (a piecewise bicubic or tricubic) with analytic gradient and Hessian.
//! - [`equirectangular`]: (lon, lat) in degrees to local metres about an origin.

/// Mean Earth radius R (m) of the local equirectangular projection.
pub const EARTH_RADIUS_M: f64 = 6_371_000.0;

/// Coefficients c with f'(t) ≈ c₀ f(p₀) + c₁ f(p₁) + c₂ f(p₂): the derivative at `t` of the
/// quadratic through the three distinct nodes p₀, p₁, p₂ (Lagrange form). Exact for every
/// quadratic f.
pub fn quadratic_slope(p: [f64; 3], t: f64) -> [f64; 3] {
    let [p0, p1, p2] = p;
    [
        ((t - p1) + (t - p2)) / ((p0 - p1) * (p0 - p2)),
        ((t - p0) + (t - p2)) / ((p1 - p0) * (p1 - p2)),
        ((t - p0) + (t - p1)) / ((p2 - p0) * (p2 - p1)),
    ]
}

/// The cubic Hermite basis at s ∈ [0, 1] of a cell of width h: f(s) = b₀ f₀ + b₁ h m₀ +
/// b₂ f₁ + b₃ h m₁ (values f, slopes m at the two ends). Returns (b, db/ds, d²b/ds²).
pub fn hermite(s: f64) -> ([f64; 4], [f64; 4], [f64; 4]) {
    let s2 = s * s;
    let s3 = s2 * s;
    (
        [
            2.0 * s3 - 3.0 * s2 + 1.0,
            s3 - 2.0 * s2 + s,
            -2.0 * s3 + 3.0 * s2,
            s3 - s2,
        ],
        [
            6.0 * s2 - 6.0 * s,
            3.0 * s2 - 4.0 * s + 1.0,
            -6.0 * s2 + 6.0 * s,
            3.0 * s2 - 2.0 * s,
        ],
        [
            12.0 * s - 6.0,
            6.0 * s - 4.0,
            -12.0 * s + 6.0,
            6.0 * s - 2.0,
        ],
    )
}

/// The basis of [`hermite`] as polynomials: b_i(s) = Σₖ `HERMITE_COEFFS[i][k]` sᵏ. A grid
/// precomputes with it, per cell, the polynomial weight of each node of its stencil.
pub const HERMITE_COEFFS: [[f64; 4]; 4] = [
    [1.0, 0.0, -3.0, 2.0],
    [0.0, 1.0, -2.0, 1.0],
    [0.0, 0.0, 3.0, -2.0],
    [0.0, 0.0, -1.0, 1.0],
];

/// Degrees to local metres about (lon₀, lat₀): x = R cos(lat₀) Δlon, y = R Δlat (angles in
/// radians, R = [`EARTH_RADIUS_M`]), Δlon wrapped into [−180°, 180°) so 0..360 and
/// −180..180 longitudes give the same x.
pub fn equirectangular(lon: f64, lat: f64, lon0: f64, lat0: f64) -> (f64, f64) {
    let dlon = (lon - lon0 + 180.0).rem_euclid(360.0) - 180.0;
    (
        EARTH_RADIUS_M * lat0.to_radians().cos() * dlon.to_radians(),
        EARTH_RADIUS_M * (lat - lat0).to_radians(),
    )
}

/// The inverse of [`equirectangular`]: local metres to (lon, lat) in degrees, lon in
/// [−180, 180).
pub fn equirectangular_inverse(x: f64, y: f64, lon0: f64, lat0: f64) -> (f64, f64) {
    let lon = lon0 + (x / (EARTH_RADIUS_M * lat0.to_radians().cos())).to_degrees();
    let lat = lat0 + (y / EARTH_RADIUS_M).to_degrees();
    ((lon + 180.0).rem_euclid(360.0) - 180.0, lat)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slope_is_exact_on_a_quadratic_at_every_node() {
        let f = |x: f64| 3.0 * x * x - 2.0 * x + 1.0;
        let df = |x: f64| 6.0 * x - 2.0;
        let p = [0.5, 1.25, 3.0];
        for t in p {
            let c = quadratic_slope(p, t);
            let got = c[0] * f(p[0]) + c[1] * f(p[1]) + c[2] * f(p[2]);
            assert!((got - df(t)).abs() < 1e-12, "{got} vs {}", df(t));
        }
    }

    #[test]
    fn hermite_basis_interpolates_values_and_slopes() {
        let (b0, d0, _) = hermite(0.0);
        let (b1, d1, _) = hermite(1.0);
        assert_eq!(b0, [1.0, 0.0, 0.0, 0.0]);
        assert_eq!(b1, [0.0, 0.0, 1.0, 0.0]);
        assert_eq!(d0, [0.0, 1.0, 0.0, 0.0]);
        assert_eq!(d1, [0.0, 0.0, 0.0, 1.0]);
    }

    #[test]
    fn hermite_coefficients_are_the_basis() {
        for k in 0..=20 {
            let s = f64::from(k) / 20.0;
            let (b, db, d2b) = hermite(s);
            for i in 0..4 {
                let c = HERMITE_COEFFS[i];
                let v = c[0] + c[1] * s + c[2] * s * s + c[3] * s * s * s;
                let d = c[1] + 2.0 * c[2] * s + 3.0 * c[3] * s * s;
                let d2 = 2.0 * c[2] + 6.0 * c[3] * s;
                assert!(
                    (v - b[i]).abs() < 1e-15 && (d - db[i]).abs() < 1e-14,
                    "{i} at {s}"
                );
                assert!((d2 - d2b[i]).abs() < 1e-14, "{i} at {s}");
            }
        }
    }

    #[test]
    fn projection_round_trips_and_wraps_longitude() {
        let (x, y) = equirectangular(359.5, 10.1, -0.5, 10.0);
        let (x2, y2) = equirectangular(-0.5, 10.1, 359.5, 10.0);
        assert!(x.abs() < 1e-6 && x2.abs() < 1e-6);
        assert!((y - EARTH_RADIUS_M * 0.1f64.to_radians()).abs() < 1e-6 && (y2 - y).abs() < 1e-9);
        let (lon, lat) = equirectangular_inverse(12_345.0, -6_789.0, 170.0, -40.0);
        let (x, y) = equirectangular(lon, lat, 170.0, -40.0);
        assert!((x - 12_345.0).abs() < 1e-6 && (y + 6_789.0).abs() < 1e-6);
    }
}
