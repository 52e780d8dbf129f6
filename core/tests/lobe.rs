//! The lobe math (`refl_core::lobe`) against f64 closed forms: the Phong
//! inverse CDF and its angle at narrow lobes where f32 `acos` fails, the
//! cone angle, Hammersley points, the hash rotation, and lobe and cone
//! sampling (angles, azimuths, truncation, stratification).

use core::f64::consts::TAU;
use refl_core::glam::{Vec2, Vec3};
use refl_core::lobe::{
    cone_ray_direction, hammersley, hash_rotation, phong_lobe_weight, pixel_hash,
    sample_phong_lobe, sample_truncated_phong_lobe, try_cone_angle_from_phong,
    try_phong_lobe_angle, try_phong_power_from_roughness, CONE_XI,
};
use refl_core::Error;

/// Powers from a diffuse lobe to a near mirror.
const POWERS: [f32; 10] = [0.0, 0.5, 1.0, 7.0, 40.0, 244.9, 1000.0, 3e4, 1e6, 3e7];

/// The f64 oracle of the lobe's angle at CDF value `xi`:
/// `acos(xi^(1 / (n + 1)))`, with `1 - cos` from `expm1` (f64 keeps 1e-16
/// where f32 keeps 6e-8).
fn oracle_angle(n: f64, xi: f64) -> f64 {
    let u = -(xi.ln() / (n + 1.0)).exp_m1();
    2.0 * (0.5 * u).sqrt().asin()
}

fn angle_between(a: Vec3, b: Vec3) -> f64 {
    let (a, b) = (a.as_dvec3().normalize(), b.as_dvec3().normalize());
    // atan2 of |a x b| and a.b: accurate at small angles.
    a.cross(b).length().atan2(a.dot(b))
}

#[test]
fn lobe_angle_keeps_relative_accuracy_for_narrow_lobes() {
    for n in POWERS {
        for energy in [0.01f32, 0.25, 0.5, 0.756, 0.95, 0.999] {
            let got = f64::from(try_phong_lobe_angle(n, energy).unwrap());
            let want = oracle_angle(f64::from(n), 1.0 - f64::from(energy));
            let rel = (got - want).abs() / want;
            assert!(
                rel < 2e-6,
                "n {n} energy {energy}: {got} vs {want} (rel {rel:e})"
            );
        }
    }
    // The plain f32 acos of the cosine loses the narrow lobe entirely: at
    // n = 3e7 the cosine rounds to 1 and acos gives 0, where the angle is
    // 2.4e-4 rad.
    let plain = libm_acos_of_cos(3e7, 0.5);
    assert_eq!(plain, 0.0);
    assert!(try_phong_lobe_angle(3e7, 0.5).unwrap() > 2e-4);
    assert_eq!(try_phong_lobe_angle(f32::INFINITY, 0.5), Ok(0.0));
}

fn libm_acos_of_cos(n: f32, energy: f32) -> f32 {
    (1.0f32 - energy).powf(1.0 / (n + 1.0)).acos()
}

#[test]
fn lobe_angle_refuses_what_it_cannot_answer() {
    for (n, e) in [
        (f32::NAN, 0.5),
        (-1.0, 0.5),
        (1.0, 0.0),
        (1.0, 1.0),
        (1.0, f32::NAN),
        (1.0, -0.1),
    ] {
        assert_eq!(
            try_phong_lobe_angle(n, e),
            Err(Error::InvalidArgument),
            "{n} {e}"
        );
    }
}

#[test]
fn cone_angle_is_the_lobe_angle_at_the_seeds_xi() {
    for n in POWERS.into_iter().filter(|&n| n <= 1024.0) {
        let cone = try_cone_angle_from_phong(n).unwrap();
        let lobe = try_phong_lobe_angle(n, 1.0 - CONE_XI).unwrap();
        let want = oracle_angle(f64::from(n), f64::from(CONE_XI));
        assert!((f64::from(cone) - want).abs() <= 2e-6 * want, "n {n}");
        assert!((cone - lobe).abs() <= 1e-6 * lobe, "n {n}");
    }
}

#[test]
fn roughness_maps_to_the_closed_form_power() {
    for r in [0.05f32, 0.1, 0.25, 0.3, 0.5, 0.9, 1.0] {
        let want = 2.0 / f64::from(r).powi(4) - 2.0;
        let got = f64::from(try_phong_power_from_roughness(r).unwrap());
        assert!(
            (got - want).abs() <= 1e-6 * want.max(1.0),
            "r {r}: {got} vs {want}"
        );
    }
    assert_eq!(try_phong_power_from_roughness(0.0), Ok(f32::INFINITY));
    assert_eq!(try_phong_power_from_roughness(1.0), Ok(0.0));
    for bad in [-0.01, 1.01, f32::NAN, f32::INFINITY] {
        assert_eq!(
            try_phong_power_from_roughness(bad),
            Err(Error::InvalidArgument)
        );
    }
}

#[test]
fn hammersley_points_are_the_radical_inverse() {
    let n = 37;
    for i in 0..n {
        let p = hammersley(i, n);
        // Radical inverse in base 2, bit by bit in f64.
        let (mut v, mut f, mut k) = (0.0f64, 0.5f64, i);
        while k > 0 {
            v += f * f64::from(k & 1);
            f *= 0.5;
            k >>= 1;
        }
        assert!((f64::from(p.x) - f64::from(i) / f64::from(n)).abs() < 1e-7);
        assert!((f64::from(p.y) - v).abs() < 1e-7, "i {i}");
        assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
    }
    assert_eq!(hammersley(0, 0), Vec2::ZERO);
}

#[test]
fn hash_rotation_is_in_the_unit_square_and_spreads() {
    let mut cells = [0u32; 16];
    for p in 0..4096u32 {
        let r = hash_rotation(pixel_hash(p));
        assert!((0.0..1.0).contains(&r.x) && (0.0..1.0).contains(&r.y));
        cells[(r.x * 4.0) as usize + 4 * (r.y * 4.0) as usize] += 1;
    }
    // 256 expected per cell; a hash that clusters would leave cells empty.
    for c in cells {
        assert!((176..=336).contains(&c), "{cells:?}");
    }
    assert_eq!(pixel_hash(0), 0);
    assert_ne!(pixel_hash(1), pixel_hash(2));
}

/// An orthonormal frame around `axis` to read a direction's azimuth.
fn azimuth(axis: Vec3, d: Vec3) -> f64 {
    let (t, b) = axis.any_orthonormal_pair();
    let (t, b) = (t.as_dvec3(), b.as_dvec3());
    let d = d.as_dvec3();
    d.dot(b).atan2(d.dot(t)).rem_euclid(TAU)
}

#[test]
fn lobe_samples_follow_the_inverse_cdf() {
    let axes = [Vec3::Z, Vec3::NEG_Y, Vec3::new(0.3, -0.5, 0.81).normalize()];
    for axis in axes {
        for n in POWERS {
            for (i, xi) in [
                (0.0f32, 0.0f32),
                (0.1, 0.3),
                (0.5, 0.5),
                (0.9, 0.99),
                (0.999, 0.7),
            ]
            .into_iter()
            .enumerate()
            {
                let d = sample_phong_lobe(axis, n, Vec2::new(xi.0, xi.1));
                assert!((d.length() - 1.0).abs() < 1e-6);
                let want = if xi.0 == 0.0 {
                    core::f64::consts::FRAC_PI_2
                } else {
                    oracle_angle(f64::from(n), f64::from(xi.0))
                };
                let got = angle_between(axis, d);
                // Relative accuracy at every width, absolute 1e-6 rad
                // (the unit vector's own rounding) at the narrowest.
                assert!(
                    (got - want).abs() <= 1e-5 * want + 1e-6,
                    "axis {axis} n {n} sample {i}: {got} vs {want}"
                );
                if want > 1e-3 {
                    let phi = azimuth(axis, d);
                    let dphi = (phi - TAU * f64::from(xi.1)).rem_euclid(TAU);
                    assert!(dphi.min(TAU - dphi) < 1e-4, "azimuth {phi} for {}", xi.1);
                }
            }
        }
    }
    assert_eq!(
        sample_phong_lobe(Vec3::X, f32::INFINITY, Vec2::new(0.0, 0.4)),
        Vec3::X
    );
}

#[test]
fn truncated_lobe_samples_stay_in_their_cone_and_match_the_oracle() {
    let axis = Vec3::new(-0.2, 0.7, 0.3).normalize();
    for n in [0.0f32, 3.0, 40.0, 900.0] {
        for max_angle in [0.05f32, 0.4, 1.2, core::f32::consts::FRAC_PI_2] {
            let c = f64::from(max_angle).cos().max(0.0);
            let c_lo = c.powf(f64::from(n) + 1.0);
            // f64 keeps 1 - y to 1e-13 relative at the narrowest cone here.
            for k in 0..64 {
                let xi = hammersley(k, 64);
                let d = sample_truncated_phong_lobe(axis, n, max_angle, xi);
                let got = angle_between(axis, d);
                // ln y = ln(c^(n+1) + xi (1 - c^(n+1))) in log space: c^(n+1)
                // underflows f64 too for n 900 at 1.2 rad.
                let k_ln = (f64::from(n) + 1.0) * c.ln();
                let b = (f64::from(xi.x) * (1.0 - c_lo)).ln();
                let (hi, lo) = (k_ln.max(b), k_ln.min(b));
                let ln_y = if lo == f64::NEG_INFINITY {
                    hi
                } else {
                    hi + (lo - hi).exp().ln_1p()
                };
                let u = -(ln_y / (f64::from(n) + 1.0)).exp_m1();
                let want = 2.0 * (0.5 * u).sqrt().asin();
                assert!(got <= f64::from(max_angle) + 1e-5, "n {n} max {max_angle}");
                assert!(
                    (got - want).abs() <= 2e-5 * want + 2e-6,
                    "n {n} max {max_angle} k {k}: {got} vs {want}"
                );
            }
        }
    }
    // max_angle pi / 2 is the whole lobe.
    let xi = Vec2::new(0.37, 0.81);
    let a = sample_truncated_phong_lobe(Vec3::Y, 12.0, core::f32::consts::FRAC_PI_2, xi);
    let b = sample_phong_lobe(Vec3::Y, 12.0, xi);
    assert!(angle_between(a, b) < 1e-6);
}

#[test]
fn hammersley_lobe_sets_hold_the_energy_they_should() {
    // With the first coordinate stratified (i / N), the share of samples
    // within the angle holding `energy` is energy within 1 / N, for any
    // power: the inverse CDF is monotone.
    let n_samples = 256u32;
    for n in POWERS {
        for energy in [0.25f32, 0.5, 0.9] {
            let angle = f64::from(try_phong_lobe_angle(n, energy).unwrap());
            let inside = (0..n_samples)
                .filter(|&i| {
                    let d = sample_phong_lobe(Vec3::Z, n, hammersley(i, n_samples));
                    angle_between(Vec3::Z, d) <= angle * (1.0 + 1e-5) + 1e-7
                })
                .count() as f64;
            let share = inside / f64::from(n_samples);
            assert!(
                (share - f64::from(energy)).abs() <= 2.0 / f64::from(n_samples),
                "n {n} energy {energy}: {share}"
            );
        }
    }
}

#[test]
fn cone_samples_are_uniform_in_solid_angle_and_keep_narrow_cones() {
    for theta in [1e-4f32, 0.01, 0.3, 1.0, 1.5] {
        let one_minus_cos = 1.0 - f64::from(theta).cos();
        let one_minus_cos = if theta < 0.01 {
            2.0 * (0.5 * f64::from(theta)).sin().powi(2)
        } else {
            one_minus_cos
        };
        for k in 0..32 {
            let xi = hammersley(k, 32);
            let d = cone_ray_direction(Vec3::Y, theta, xi);
            let got = angle_between(Vec3::Y, d);
            // Uniform in solid angle: 1 - cos t = xi.x (1 - cos theta).
            let want = (1.0 - f64::from(xi.x) * one_minus_cos).acos();
            let want = if theta < 0.01 {
                2.0 * (0.5 * f64::from(xi.x) * one_minus_cos).sqrt().asin()
            } else {
                want
            };
            assert!(got <= f64::from(theta) * (1.0 + 1e-5) + 1e-7);
            assert!(
                (got - want).abs() <= 2e-5 * want + 1e-6,
                "theta {theta} k {k}: {got} vs {want}"
            );
        }
    }
}

#[test]
fn lobe_weight_is_the_cosine_power() {
    for (cos, n) in [(0.5f32, 2.0f32), (0.9, 40.0), (0.999, 1e4), (1.0, 1e6)] {
        let want = f64::from(cos).powf(f64::from(n));
        let got = f64::from(phong_lobe_weight(cos, n));
        assert!((got - want).abs() <= 1e-5 * want.max(1e-30), "{cos} {n}");
    }
    assert_eq!(phong_lobe_weight(-0.1, 3.0), 0.0);
    assert_eq!(phong_lobe_weight(0.0, 3.0), 0.0);
    assert_eq!(phong_lobe_weight(1.5, 3.0), 1.0);
}

#[test]
fn samples_of_every_axis_are_unit_and_finite() {
    // Axes along the coordinate axes and near them (the orthonormal pair's
    // branch), stiff powers and rotations at the unit square's edge.
    let axes = [
        Vec3::X,
        Vec3::NEG_Z,
        Vec3::new(1e-7, 0.0, -1.0).normalize(),
        Vec3::new(0.0, -1.0, 1e-30).normalize(),
    ];
    for axis in axes {
        for n in [0.0f32, 1e-30, 1e30, f32::MAX] {
            for xi in [Vec2::ZERO, Vec2::splat(0.999_999_94), Vec2::new(1e-38, 0.5)] {
                for d in [
                    sample_phong_lobe(axis, n, xi),
                    sample_truncated_phong_lobe(axis, n, 1.0, xi),
                    sample_truncated_phong_lobe(axis, n, core::f32::consts::FRAC_PI_2, xi),
                    sample_truncated_phong_lobe(axis, n, 1e-30, xi),
                    cone_ray_direction(axis, 1.5, xi),
                ] {
                    assert!(
                        d.is_finite() && (d.length() - 1.0).abs() < 1e-5,
                        "{axis} {n} {xi}"
                    );
                    assert!(d.dot(axis) >= -1e-6, "{axis} {n} {xi}: below the horizon");
                }
            }
        }
    }
}
