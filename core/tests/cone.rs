//! Glossy cone tracing (seed 004 Sec. 4.4.2, 4.4.4, 4.4.5, 4.5.x, 4.6.1,
//! 4.6.8) and the multi-ray alternative (seed 003 Sec. 3.5) against f64
//! oracles and closed forms.
#![cfg(feature = "cone")]
#![allow(clippy::needless_range_loop, clippy::too_many_arguments)]

use glam::{Vec2, Vec3};
use refl_core::cone::{
    blend_fade, cone_mip_level, cone_ray_direction, convolution_weights, isosceles_inradius,
    isosceles_opposite, phong_lobe_weight, try_build_color_level0_rows, try_build_color_level_rows,
    try_build_visibility_level0_rows, try_build_visibility_level_rows,
    try_phong_power_from_roughness, ConeCircles, CONE_XI, DEFAULT_SIGMA,
};
use refl_core::{
    try_build_color_pyramid, try_build_hiz, try_build_visibility_pyramid, try_color_pyramid_len,
    try_cone_angle_from_phong, try_cone_angle_from_roughness, try_cone_trace, try_multiray,
    try_visibility_pyramid_len, Camera, ColorTexel, Cone, ConeOptions, ConePyramids,
    DepthConvention, DepthImage, Error, FadeRange, Fades, HiZ, HiZLayout, HiZOptions, HiZTexel,
    ImageView, MultiRayOptions, PyramidStamp, Ray, RowRange, Thickness,
};
use refl_core::{
    try_stamp_color_pyramid, try_stamp_visibility_pyramid, COLOR_STAMP_TEXELS, VISIBILITY_STAMP_LEN,
};

// ---------------------------------------------------------------- helpers

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn f(&mut self) -> f32 {
        ((self.next() >> 40) as f64 / (1u64 << 24) as f64) as f32
    }
}

const FAR: f32 = 100.0;

fn camera(w: u32, h: u32) -> Camera {
    Camera::try_look_at(
        Vec3::ZERO,
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::Y,
        60f32.to_radians(),
        0.1,
        FAR,
        w,
        h,
    )
    .unwrap()
}

/// Linear depth (f64) of a scene seen by `camera(w, h)`: a floor `y = -1`
/// and a back wall `z = -wall`; `None` for the background.
fn scene_depth(w: u32, h: u32, wall: f64, x: u32, y: u32) -> Option<f64> {
    let tan_y = (30f64).to_radians().tan();
    let tan_x = tan_y * w as f64 / h as f64;
    let nx = 2.0 * (x as f64 + 0.5) / w as f64 - 1.0;
    let ny = 1.0 - 2.0 * (y as f64 + 0.5) / h as f64;
    let _ = nx * tan_x;
    // Direction (nx tan_x, ny tan_y, -1): linear depth = t.
    let mut best = if wall > 0.0 { Some(wall) } else { None };
    let dy = ny * tan_y;
    if dy < 0.0 {
        let t = 1.0 / -dy;
        if best.is_none_or(|b| t < b) {
            best = Some(t);
        }
    }
    best.filter(|&z| z < FAR as f64)
}

fn encode(cam: &Camera, z: Option<f64>, c: DepthConvention) -> f32 {
    match z {
        Some(z) => cam.encode_depth(z as f32, c),
        None => match c {
            DepthConvention::Linear => FAR,
            DepthConvention::ZeroToOne => 1.0,
            DepthConvention::ReversedZ => 0.0,
        },
    }
}

struct Frame {
    cam: Camera,
    depth: Vec<f32>,
    hiz: Vec<HiZTexel>,
    color: Vec<ColorTexel>,
    vis: Vec<f32>,
    conv: DepthConvention,
}

impl Frame {
    fn new(
        w: u32,
        h: u32,
        wall: f64,
        conv: DepthConvention,
        paint: impl Fn(u32, u32) -> ColorTexel,
    ) -> Frame {
        let cam = camera(w, h);
        let depth: Vec<f32> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| encode(&cam, scene_depth(w, h, wall, x, y), conv))
            .collect();
        let img: Vec<ColorTexel> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| paint(x, y))
            .collect();
        let mut hiz = vec![[0.0; 2]; refl_core::try_hiz_len(w, h).unwrap()];
        let di =
            DepthImage::try_new(ImageView::try_new(&depth, w, h, w).unwrap(), cam, conv).unwrap();
        try_build_hiz(&mut hiz, &di).unwrap();
        let mut color = vec![[0.0; 3]; try_color_pyramid_len(w, h).unwrap()];
        try_build_color_pyramid(
            &mut color,
            &ImageView::try_new(&img, w, h, w).unwrap(),
            DEFAULT_SIGMA,
        )
        .unwrap();
        let mut vis = vec![0.0; try_visibility_pyramid_len(w, h).unwrap()];
        {
            let hz = HiZ::try_new(&hiz, cam, conv).unwrap();
            try_build_visibility_pyramid(&mut vis, &hz).unwrap();
        }
        Frame {
            cam,
            depth,
            hiz,
            color,
            vis,
            conv,
        }
    }
    fn pyramids(&self) -> ConePyramids<'_> {
        ConePyramids::try_new(
            HiZ::try_new(&self.hiz, self.cam, self.conv).unwrap(),
            &self.color,
            &self.vis,
        )
        .unwrap()
    }
}

// ------------------------------------------------------------ cone angle

#[test]
fn cone_angle_matches_f64_inverse_cdf_and_blends_to_zero() {
    for &p in &[0.0f32, 0.5, 1.0, 2.0, 10.0, 100.0, 500.0, 1023.0, 1024.0] {
        let oracle = (CONE_XI as f64).powf(1.0 / (p as f64 + 1.0)).acos();
        let got = try_cone_angle_from_phong(p).unwrap() as f64;
        assert!(
            (got - oracle).abs() <= 2e-6 * oracle.max(1e-3),
            "{p}: {got} {oracle}"
        );
    }
    // acos, not cos (design.md erratum): power 0 gives acos(0.244) ~ 75.9 deg.
    let t0 = try_cone_angle_from_phong(0.0).unwrap();
    assert!(
        (t0.to_degrees() - 75.877).abs() < 0.01,
        "{}",
        t0.to_degrees()
    );
    // The 1024..2048 blend: half way at 1536, 0 at 2048 and beyond.
    let full = (CONE_XI as f64).powf(1.0 / 1537.0).acos();
    let half = try_cone_angle_from_phong(1536.0).unwrap() as f64;
    assert!(
        (half - 0.5 * full).abs() < 1e-6 * full.max(1.0),
        "{half} {full}"
    );
    assert_eq!(try_cone_angle_from_phong(2048.0), Ok(0.0));
    assert_eq!(try_cone_angle_from_phong(1e9), Ok(0.0));
    assert_eq!(try_cone_angle_from_phong(f32::INFINITY), Ok(0.0));
    // Monotone decreasing in the power.
    let mut prev = f32::INFINITY;
    for i in 0..200 {
        let t = try_cone_angle_from_phong(i as f32 * 12.0).unwrap();
        assert!(t <= prev);
        prev = t;
    }
    assert_eq!(
        try_cone_angle_from_phong(f32::NAN),
        Err(Error::InvalidArgument)
    );
    assert_eq!(try_cone_angle_from_phong(-1.0), Err(Error::InvalidArgument));
}

#[test]
fn roughness_mapping_matches_closed_form() {
    for &r in &[0.05f32, 0.1, 0.25, 0.5, 0.75, 1.0] {
        let a = (r as f64).powi(2);
        let power = 2.0 / (a * a) - 2.0;
        let got = try_phong_power_from_roughness(r).unwrap() as f64;
        assert!((got - power).abs() <= 1e-5 * power.max(1.0), "{r}");
        let theta = if power >= 2048.0 {
            0.0
        } else if power > 1024.0 {
            (CONE_XI as f64).powf(1.0 / (power + 1.0)).acos() * (2048.0 - power) / 1024.0
        } else {
            (CONE_XI as f64).powf(1.0 / (power + 1.0)).acos()
        };
        let t = try_cone_angle_from_roughness(r).unwrap() as f64;
        assert!((t - theta).abs() < 1e-5, "{r}: {t} {theta}");
    }
    assert_eq!(try_phong_power_from_roughness(0.0), Ok(f32::INFINITY));
    assert_eq!(try_cone_angle_from_roughness(0.0), Ok(0.0));
    for bad in [f32::NAN, -0.1, 1.5, f32::INFINITY] {
        assert_eq!(
            try_cone_angle_from_roughness(bad),
            Err(Error::InvalidArgument)
        );
    }
}

// ------------------------------------------------ isosceles triangle

/// In-radius by area / semi-perimeter, f64.
fn inradius64(a: f64, h: f64) -> f64 {
    let side = (h * h + 0.25 * a * a).sqrt();
    0.5 * a * h / (0.5 * (a + 2.0 * side))
}

#[test]
fn inradius_matches_area_over_semiperimeter_for_stiff_cones() {
    for &theta in &[1e-4f64, 1e-3, 0.05, 0.5, 1.0, 1.5, 89f64.to_radians()] {
        for &h in &[1e-3f64, 0.3, 1.0, 17.0, 1e3, 1e6] {
            let a32 = isosceles_opposite(h as f32, theta as f32);
            let a = 2.0 * theta.tan() * h;
            assert!((a32 as f64 - a).abs() <= 2e-6 * a, "opp {theta} {h}");
            let r = isosceles_inradius(a32, h as f32) as f64;
            let oracle = inradius64(a, h);
            assert!(
                (r - oracle).abs() <= 4e-6 * oracle,
                "theta {theta} h {h}: {r} vs {oracle}"
            );
            assert!(r > 0.0 && r <= 0.5 * h * (1.0 + 1e-6));
        }
    }
    // The seed's printed form cancels in f32 when the base is much longer
    // than the height (wide cones): at 89.9 degrees it is far off.
    let (h, theta) = (100.0f32, 89.9f32.to_radians());
    let a = isosceles_opposite(h, theta);
    let seed = a * ((a * a + 4.0 * h * h).sqrt() - a) / (4.0 * h);
    let oracle = inradius64(a as f64, h as f64);
    assert!(((seed as f64) - oracle).abs() > 1e-3 * oracle);
    assert!(((isosceles_inradius(a, h) as f64) - oracle).abs() < 1e-6 * oracle);
    assert_eq!(isosceles_inradius(0.0, 1.0), 0.0);
    assert_eq!(isosceles_inradius(1.0, 0.0), 0.0);
    assert_eq!(isosceles_inradius(f32::NAN, 1.0), 0.0);
    // Huge sides do not overflow.
    let r = isosceles_inradius(3e38, 3e38);
    assert!(r.is_finite() && r > 0.0);
}

#[test]
fn circles_follow_f64_sequence_and_touch() {
    for &theta in &[1e-4f64, 0.02, 0.3, 1.0, 89f64.to_radians()] {
        for &len in &[0.2f64, 3.0, 100.0, 5000.0, 1e5] {
            let mut adj = len;
            let circles: Vec<_> = ConeCircles::try_new(len as f32, theta as f32, 16)
                .unwrap()
                .collect();
            // The sequence ends early only when the height underflows
            // (wide cones shrink it by ~1e-4 per circle at 89 degrees).
            assert!(
                circles.len() == 16 || theta > 1.5,
                "{theta} {len}: {}",
                circles.len()
            );
            assert!(!circles.is_empty());
            for (k, c) in circles.iter().enumerate() {
                let r = inradius64(2.0 * theta.tan() * adj, adj);
                let center = adj - r;
                // Relative to the first height: the sequence subtracts, so
                // errors are relative to the starting length.
                let tol = 1e-5 * len;
                assert!(
                    (c.radius as f64 - r).abs() <= tol,
                    "theta {theta} len {len} k {k}: r {} vs {r}",
                    c.radius
                );
                assert!((c.center as f64 - center).abs() <= tol);
                if k + 1 < circles.len() {
                    // Adjacent circles touch: the next one's far edge is
                    // this one's near edge.
                    let n = circles[k + 1];
                    assert!(
                        ((n.center + n.radius) - (c.center - c.radius)).abs() <= 1e-5 * len as f32
                    );
                    assert!(n.radius <= c.radius);
                }
                adj -= 2.0 * r;
            }
        }
    }
    // Circles smaller than a pixel and larger than the screen.
    let tiny: Vec<_> = ConeCircles::try_new(50.0, 1e-4, 4).unwrap().collect();
    assert!(tiny[0].radius < 0.01);
    assert_eq!(cone_mip_level(tiny[0].radius, 0.0), 0.0);
    let huge: Vec<_> = ConeCircles::try_new(1e5, 89f32.to_radians(), 2)
        .unwrap()
        .collect();
    assert!(huge[0].radius > 4.9e4);
    let lvl = cone_mip_level(huge[0].radius, 0.0) as f64;
    assert!((lvl - (2.0 * huge[0].radius as f64).log2()).abs() < 1e-4);
    assert!(ConeCircles::try_new(f32::NAN, 0.1, 4).is_err());
    assert!(ConeCircles::try_new(1.0, f32::NAN, 4).is_err());
    assert!(ConeCircles::try_new(1.0, 2.0, 4).is_err());
    assert!(ConeCircles::try_new(-1.0, 0.1, 4).is_err());
    assert!(ConeCircles::try_new(f32::INFINITY, 0.1, 4).is_err());
    assert_eq!(ConeCircles::try_new(0.0, 0.1, 4).unwrap().count(), 0);
}

// ------------------------------------------------------------ pyramids

#[test]
fn convolution_weights_sum_to_exactly_one() {
    for &sigma in &[0.5f32, 0.84, DEFAULT_SIGMA, 1.7, 3.0] {
        for fine in 1..40u32 {
            let coarse = (fine / 2).max(1);
            for i in 0..coarse {
                let (_, n, w) = convolution_weights(i, coarse, fine, sigma);
                let mut s = 0.0f32;
                for wk in w.iter().take(n) {
                    assert!(*wk >= 0.0);
                    s += *wk;
                }
                assert_eq!(s, 1.0, "sigma {sigma} fine {fine} i {i}");
            }
        }
    }
}

/// f64 oracle of one coarse color texel: 2D Gaussian over the footprint
/// center, clamped edges, normalized in f64.
fn convolve64(
    fine: &[ColorTexel],
    fw: u32,
    fh: u32,
    cw: u32,
    ch: u32,
    i: u32,
    j: u32,
    s: f64,
) -> [f64; 3] {
    let span = |c: u32, coarse: u32, full: u32| {
        let lo = 2 * c as i64;
        let hi = if c + 1 >= coarse { full as i64 } else { lo + 2 };
        (lo, hi)
    };
    let (xl, xh) = span(i, cw, fw);
    let (yl, yh) = span(j, ch, fh);
    let (cx, cy) = ((xl + xh) as f64 * 0.5, (yl + yh) as f64 * 0.5);
    let mut acc = [0.0f64; 3];
    let mut wsum = 0.0;
    for y in yl - 3..yh + 3 {
        for x in xl - 3..xh + 3 {
            let dx = x as f64 + 0.5 - cx;
            let dy = y as f64 + 0.5 - cy;
            let wgt = (-(dx * dx) / (2.0 * s * s)).exp() * (-(dy * dy) / (2.0 * s * s)).exp();
            let t =
                fine[(y.clamp(0, fh as i64 - 1) * fw as i64 + x.clamp(0, fw as i64 - 1)) as usize];
            for k in 0..3 {
                acc[k] += wgt * t[k] as f64;
            }
            wsum += wgt;
        }
    }
    acc.map(|a| a / wsum)
}

#[test]
fn color_pyramid_matches_f64_convolution_and_keeps_constants() {
    let mut rng = Rng(7);
    for &(w, h) in &[(37u32, 23u32), (64, 64), (5, 1), (1, 9), (2, 3)] {
        let img: Vec<ColorTexel> = (0..w * h)
            .map(|_| [rng.f(), rng.f() * 4.0, rng.f() - 0.5])
            .collect();
        let layout = HiZLayout::try_new(w, h).unwrap();
        let mut pyr = vec![[9.0; 3]; try_color_pyramid_len(w, h).unwrap()];
        try_build_color_pyramid(&mut pyr, &ImageView::try_new(&img, w, h, w).unwrap(), 1.0)
            .unwrap();
        assert_eq!(&pyr[..(w * h) as usize], &img[..]);
        for level in 1..layout.level_count() {
            let (f, c) = (
                layout.level(level - 1).unwrap(),
                layout.level(level).unwrap(),
            );
            assert_eq!(c.width, (f.width / 2).max(1));
            assert_eq!(c.height, (f.height / 2).max(1));
            let fine = &pyr[f.range()];
            for j in 0..c.height {
                for i in 0..c.width {
                    let o = convolve64(fine, f.width, f.height, c.width, c.height, i, j, 1.0);
                    let got = pyr[c.offset + (j * c.width + i) as usize];
                    for k in 0..3 {
                        assert!(
                            (got[k] as f64 - o[k]).abs() < 1e-5,
                            "{w}x{h} L{level} ({i},{j})"
                        );
                    }
                }
            }
        }
        // A constant image stays exactly constant on every level.
        let v = [0.3f32, 1.7, 0.123_456_7];
        let flat = vec![v; (w * h) as usize];
        try_build_color_pyramid(&mut pyr, &ImageView::try_new(&flat, w, h, w).unwrap(), 1.3)
            .unwrap();
        let levels = HiZLayout::try_new(w, h).unwrap().len();
        assert!(pyr[..levels].iter().all(|&t| t == v));
        // Then the stamp: the frame size.
        assert_eq!(pyr.len(), levels + COLOR_STAMP_TEXELS);
        assert_eq!(
            PyramidStamp::read(&pyr, w, h),
            Some(PyramidStamp::of_size(w, h))
        );
    }
}

#[test]
fn color_pyramid_rejects_bad_input_and_writes_nothing() {
    let (w, h) = (8u32, 6u32);
    let mut img = vec![[0.5f32; 3]; 48];
    let n = try_color_pyramid_len(w, h).unwrap();
    let mut dst = vec![[7.0f32; 3]; n];
    assert_eq!(
        try_build_color_pyramid(
            &mut dst[..n - 1],
            &ImageView::try_new(&img, w, h, w).unwrap(),
            1.0
        ),
        Err(Error::InsufficientSize)
    );
    for s in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        assert_eq!(
            try_build_color_pyramid(&mut dst, &ImageView::try_new(&img, w, h, w).unwrap(), s),
            Err(Error::InvalidArgument)
        );
    }
    img[47] = [f32::NAN, 0.0, 0.0];
    assert_eq!(
        try_build_color_pyramid(&mut dst, &ImageView::try_new(&img, w, h, w).unwrap(), 1.0),
        Err(Error::InvalidArgument)
    );
    img[47] = [0.0, f32::INFINITY, 0.0];
    assert_eq!(
        try_build_color_level0_rows(
            &mut dst,
            &ImageView::try_new(&img, w, h, w).unwrap(),
            RowRange::try_all(h).unwrap()
        ),
        Err(Error::InvalidArgument)
    );
    assert!(dst.iter().all(|&t| t == [7.0; 3]));
    let layout = HiZLayout::try_new(w, h).unwrap();
    let fine = vec![[1.0f32; 3]; 48];
    assert_eq!(
        try_build_color_level_rows(
            &mut dst,
            &fine,
            &layout,
            0,
            RowRange::try_all(1).unwrap(),
            1.0
        ),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        try_build_color_level_rows(
            &mut dst,
            &fine[..47],
            &layout,
            1,
            RowRange::try_all(3).unwrap(),
            1.0
        ),
        Err(Error::InsufficientSize)
    );
    assert_eq!(
        try_build_color_level_rows(
            &mut dst,
            &fine,
            &layout,
            9,
            RowRange::try_all(1).unwrap(),
            1.0
        ),
        Err(Error::InvalidArgument)
    );
    assert!(dst.iter().all(|&t| t == [7.0; 3]));
}

#[test]
fn row_bands_equal_whole_builds() {
    let (w, h) = (21u32, 13u32);
    let mut rng = Rng(3);
    let img: Vec<ColorTexel> = (0..w * h).map(|_| [rng.f(), rng.f(), rng.f()]).collect();
    let view = ImageView::try_new(&img, w, h, w).unwrap();
    let layout = HiZLayout::try_new(w, h).unwrap();
    let mut whole = vec![[0.0; 3]; try_color_pyramid_len(w, h).unwrap()];
    try_build_color_pyramid(&mut whole, &view, 1.0).unwrap();
    let mut banded = vec![[0.0; 3]; try_color_pyramid_len(w, h).unwrap()];
    let l0 = layout.level(0).unwrap();
    for (a, b) in [(0u32, 5u32), (5, 13)] {
        let r = layout
            .rows_range(0, RowRange::try_new(a, b, h).unwrap())
            .unwrap();
        try_build_color_level0_rows(&mut banded[r], &view, RowRange::try_new(a, b, h).unwrap())
            .unwrap();
    }
    assert_eq!(l0.offset, 0);
    for level in 1..layout.level_count() {
        let (f, c) = (
            layout.level(level - 1).unwrap(),
            layout.level(level).unwrap(),
        );
        let (head, tail) = banded.split_at_mut(c.offset);
        let mid = c.height / 2;
        for (a, b) in [(0, mid), (mid, c.height)] {
            if a == b {
                continue;
            }
            let rows = RowRange::try_new(a, b, c.height).unwrap();
            let lo = (a * c.width) as usize;
            let hi = (b * c.width) as usize;
            try_build_color_level_rows(
                &mut tail[lo..hi],
                &head[f.range()],
                &layout,
                level,
                rows,
                1.0,
            )
            .unwrap();
        }
    }
    // A row-band build ends with the stamp.
    try_stamp_color_pyramid(&mut banded, w, h).unwrap();
    assert_eq!(whole, banded);

    // Visibility, banded vs whole, on the floor/wall frame.
    let fr = Frame::new(w, h, 8.0, DepthConvention::ReversedZ, |_, _| [1.0; 3]);
    let hz = HiZ::try_new(&fr.hiz, fr.cam, fr.conv).unwrap();
    let mut vb = vec![0.0f32; try_visibility_pyramid_len(w, h).unwrap()];
    for (a, b) in [(0u32, 7u32), (7, 13)] {
        let r = layout
            .rows_range(0, RowRange::try_new(a, b, h).unwrap())
            .unwrap();
        try_build_visibility_level0_rows(&mut vb[r], &hz, RowRange::try_new(a, b, h).unwrap())
            .unwrap();
    }
    for level in 1..layout.level_count() {
        let (f, c) = (
            layout.level(level - 1).unwrap(),
            layout.level(level).unwrap(),
        );
        let (head, tail) = vb.split_at_mut(c.offset);
        try_build_visibility_level_rows(
            &mut tail[..c.len()],
            &head[f.range()],
            &hz,
            level,
            RowRange::try_all(c.height).unwrap(),
        )
        .unwrap();
    }
    try_stamp_visibility_pyramid(&mut vb, &hz).unwrap();
    assert_eq!(
        vb.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        fr.vis.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
}

/// f64 oracle of the visibility pyramid (module docs of `cone`).
fn visibility64(w: u32, h: u32, wall: f64) -> Vec<Vec<f64>> {
    let layout = HiZLayout::try_new(w, h).unwrap();
    // Per level: (visibility, closest, farthest) per texel, foreground only.
    // (closest foreground or None, farthest including the background).
    let mut z: Vec<(Option<f64>, f64)> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| match scene_depth(w, h, wall, x, y) {
            Some(d) => (Some(d), d),
            None => (None, FAR as f64),
        })
        .collect();
    let mut v: Vec<f64> = z
        .iter()
        .map(|t| if t.0.is_some() { 1.0 } else { 0.0 })
        .collect();
    let mut out = vec![v.clone()];
    for level in 1..layout.level_count() {
        let (f, c) = (
            layout.level(level - 1).unwrap(),
            layout.level(level).unwrap(),
        );
        let mut nz = vec![(None, 0.0); c.len()];
        let mut nv = vec![0.0; c.len()];
        for j in 0..c.height {
            for i in 0..c.width {
                let xs = 2 * i..if i + 1 >= c.width { f.width } else { 2 * i + 2 };
                let ys = 2 * j..if j + 1 >= c.height {
                    f.height
                } else {
                    2 * j + 2
                };
                let kids: Vec<(f64, (Option<f64>, f64))> = ys
                    .clone()
                    .flat_map(|y| xs.clone().map(move |x| (x, y)))
                    .map(|(x, y)| {
                        let k = (y * f.width + x) as usize;
                        (v[k], z[k])
                    })
                    .collect();
                let lo = kids
                    .iter()
                    .filter_map(|k| k.1 .0)
                    .fold(f64::INFINITY, f64::min);
                let hi = kids
                    .iter()
                    .filter(|k| k.1 .0.is_some())
                    .map(|k| k.1 .1)
                    .fold(f64::NEG_INFINITY, f64::max);
                let far_all = kids
                    .iter()
                    .map(|k| k.1 .1)
                    .fold(f64::NEG_INFINITY, f64::max);
                let range = hi - lo;
                let flat = !(range > 1e-6 * hi);
                let mut s = 0.0;
                for (vk, zk) in &kids {
                    if let (Some(zmin), _) = zk {
                        s += vk * if flat { 1.0 } else { 1.0 - (zmin - lo) / range };
                    }
                }
                let k = (j * c.width + i) as usize;
                nv[k] = s / kids.len() as f64;
                nz[k] = (lo.is_finite().then_some(lo), far_all);
            }
        }
        v = nv;
        z = nz;
        out.push(v.clone());
    }
    out
}

#[test]
fn visibility_pyramid_matches_f64_oracle_in_all_conventions() {
    for &(w, h) in &[(33u32, 17u32), (16, 16)] {
        for &wall in &[6.0f64, 0.0] {
            let oracle = visibility64(w, h, wall);
            for conv in DepthConvention::ALL {
                let fr = Frame::new(w, h, wall, conv, |_, _| [0.0; 3]);
                let layout = HiZLayout::try_new(w, h).unwrap();
                for (level, o) in oracle.iter().enumerate() {
                    let l = layout.level(level as u32).unwrap();
                    for (k, ov) in o.iter().enumerate() {
                        let got = fr.vis[l.offset + k] as f64;
                        assert!(
                            (got - ov).abs() < 2e-3,
                            "{conv:?} {w}x{h} wall {wall} L{level} #{k}: {got} vs {ov}"
                        );
                        assert!((0.0..=1.0).contains(&got));
                    }
                }
            }
        }
    }
    // A fronto-parallel wall is flat in every cell: visibility 1 everywhere.
    let fr = Frame::new(24, 24, 3.0, DepthConvention::Linear, |_, _| [0.0; 3]);
    // The floor is hidden behind... no: the floor is in front of the wall in
    // the lower rows; check the top half of level 0 and 1 only.
    let layout = HiZLayout::try_new(24, 24).unwrap();
    let l1 = layout.level(1).unwrap();
    for j in 0..4 {
        for i in 0..12 {
            assert_eq!(fr.vis[l1.offset + (j * 12 + i) as usize], 1.0);
        }
    }
}

// ------------------------------------------------------------ cone trace

fn cone(apex: Vec2, hit: Vec2, za: f32, zh: f32, theta: f32) -> Cone {
    Cone {
        apex,
        apex_depth: za,
        hit,
        hit_depth: zh,
        theta,
        n_dot_v: 1.0,
        travel: 0.0,
    }
}

#[test]
fn uniform_scene_reflects_its_color_exactly() {
    let c = [0.25f32, 0.6, 0.9];
    for conv in DepthConvention::ALL {
        let fr = Frame::new(40, 30, 7.0, conv, |_, _| c);
        let p = fr.pyramids();
        let mut rng = Rng(11);
        for _ in 0..300 {
            let apex = Vec2::new(rng.f() * 40.0, rng.f() * 30.0);
            let hit = Vec2::new(rng.f() * 40.0, rng.f() * 30.0);
            let theta = rng.f() * 1.5;
            for opts in [
                ConeOptions::default(),
                ConeOptions {
                    max_circles: 16,
                    use_visibility: false,
                    max_stretch: 4.0,
                    level_bias: -1.0,
                    depth_tolerance: 0.0,
                    normalize: true,
                },
            ] {
                let mut k = cone(apex, hit, 1.0 + rng.f() * 5.0, 2.0 + rng.f() * 5.0, theta);
                k.n_dot_v = rng.f();
                k.travel = rng.f() * 20.0;
                let r = try_cone_trace(&p, &k, c, &opts).unwrap();
                assert_eq!(r.color, c);
                assert!((0.0..=1.0).contains(&r.coverage));
            }
        }
    }
}

#[test]
fn opaque_wall_covers_the_cone_and_hides_the_fallback() {
    // Only a fronto-parallel wall (the floor is below the view: camera
    // looks straight ahead, the floor fills the lower half; use the upper
    // half). Every cell is flat, so visibility and sphere weight are 1.
    let c = [0.8f32, 0.1, 0.3];
    for conv in DepthConvention::ALL {
        let fr = Frame::new(64, 48, 5.0, conv, |_, _| c);
        let p = fr.pyramids();
        for &theta in &[1e-4f32, 0.05, 0.3] {
            let k = cone(Vec2::new(10.0, 6.0), Vec2::new(50.0, 8.0), 5.0, 5.0, theta);
            let r = try_cone_trace(&p, &k, [0.0, 0.0, 1.0], &ConeOptions::default()).unwrap();
            assert_eq!(r.coverage, 1.0, "{conv:?} {theta}");
            for k in 0..3 {
                assert!((r.color[k] - c[k]).abs() < 1e-6);
            }
        }
    }
}

#[test]
fn background_returns_the_fallback() {
    // No wall: the upper half is background (sky).
    let fr = Frame::new(32, 32, 0.0, DepthConvention::ReversedZ, |_, _| [5.0; 3]);
    let p = fr.pyramids();
    let f = [0.1, 0.2, 0.3];
    let k = cone(Vec2::new(4.0, 3.0), Vec2::new(28.0, 4.0), 3.0, 50.0, 0.2);
    let r = try_cone_trace(&p, &k, f, &ConeOptions::default()).unwrap();
    assert_eq!(r.coverage, 0.0);
    assert_eq!(r.color, f);
}

#[test]
fn narrow_cone_reads_the_hit_texel_and_wide_cone_blurs() {
    // A checkerboard of 1-pixel cells on the wall: a 1e-4 rad cone reads
    // (bilinearly, level 0) the texel at the hit; a wide cone reads a
    // coarse level whose value approaches the mean 0.5.
    let fr = Frame::new(64, 64, 5.0, DepthConvention::ZeroToOne, |x, y| {
        let v = ((x + y) % 2) as f32;
        [v, v, v]
    });
    let p = fr.pyramids();
    let hit = Vec2::new(40.5, 10.5);
    let opts = ConeOptions {
        use_visibility: false,
        ..ConeOptions::default()
    };
    let r = try_cone_trace(
        &p,
        &cone(Vec2::new(8.5, 12.5), hit, 4.5, 5.0, 1e-4),
        [9.0; 3],
        &opts,
    )
    .unwrap();
    assert_eq!(r.coverage, 1.0);
    let expect = ((40 + 10) % 2) as f32;
    assert!((r.color[0] - expect).abs() < 0.01, "{:?}", r.color);
    let wide = try_cone_trace(
        &p,
        &cone(Vec2::new(8.5, 12.5), hit, 5.0, 5.0, 0.6),
        [9.0; 3],
        &opts,
    )
    .unwrap();
    assert_eq!(wide.coverage, 1.0);
    assert!((wide.color[0] - 0.5).abs() < 0.1, "{:?}", wide.color);
}

#[test]
fn first_circle_is_a_trilinear_sample_of_the_pyramid() {
    // One circle, no visibility, flat wall: the result is the trilinear
    // color at the first circle's center and level (f64 oracle of the
    // bilinear/trilinear filter over the built pyramid).
    let mut rng = Rng(5);
    let img: Vec<ColorTexel> = (0..48 * 40).map(|_| [rng.f(), rng.f(), rng.f()]).collect();
    let fr = Frame::new(48, 40, 6.0, DepthConvention::Linear, |x, y| {
        img[(y * 48 + x) as usize]
    });
    let p = fr.pyramids();
    let layout = HiZLayout::try_new(48, 40).unwrap();
    let bil = |level: u32, q: Vec2| -> [f64; 3] {
        let l = layout.level(level).unwrap();
        let u = q.x as f64 * l.width as f64 / 48.0 - 0.5;
        let v = q.y as f64 * l.height as f64 / 40.0 - 0.5;
        let (x0, y0) = (u.floor(), v.floor());
        let (fx, fy) = (u - x0, v - y0);
        let t = |x: f64, y: f64| {
            let x = (x as i64).clamp(0, l.width as i64 - 1) as usize;
            let y = (y as i64).clamp(0, l.height as i64 - 1) as usize;
            fr.color[l.offset + y * l.width as usize + x].map(f64::from)
        };
        let mut o = [0.0; 3];
        for k in 0..3 {
            let a = t(x0, y0)[k] * (1.0 - fx) + t(x0 + 1.0, y0)[k] * fx;
            let b = t(x0, y0 + 1.0)[k] * (1.0 - fx) + t(x0 + 1.0, y0 + 1.0)[k] * fx;
            o[k] = a * (1.0 - fy) + b * fy;
        }
        o
    };
    for _ in 0..50 {
        let apex = Vec2::new(2.0 + rng.f() * 44.0, 1.0 + rng.f() * 10.0);
        let hit = Vec2::new(2.0 + rng.f() * 44.0, 1.0 + rng.f() * 10.0);
        let theta = rng.f() * 0.5;
        let opts = ConeOptions {
            max_circles: 1,
            use_visibility: false,
            ..ConeOptions::default()
        };
        let r = try_cone_trace(&p, &cone(apex, hit, 7.0, 7.0, theta), [0.0; 3], &opts).unwrap();
        let len = (hit - apex).length();
        let c = ConeCircles::try_new(len, theta, 1).unwrap().next();
        let Some(c) = c else { continue };
        let q = apex + (hit - apex) / len * c.center;
        let lvl = cone_mip_level(c.radius, 0.0) as f64;
        let last = (layout.level_count() - 1) as f64;
        let l0 = lvl.floor().min(last);
        let t = if l0 >= last { 0.0 } else { lvl - l0 };
        let a = bil(l0 as u32, q);
        let b = if t > 0.0 { bil(l0 as u32 + 1, q) } else { a };
        for k in 0..3 {
            let o = a[k] + (b[k] - a[k]) * t;
            assert!(
                (r.color[k] as f64 - o).abs() < 1e-4,
                "{} vs {o}",
                r.color[k]
            );
        }
    }
}

#[test]
fn sphere_above_the_surface_takes_nothing() {
    // The cone passes in front of the wall (its depth far smaller than the
    // wall's): the sphere lies above every cell, the fallback stays.
    let fr = Frame::new(32, 32, 20.0, DepthConvention::Linear, |_, _| [1.0; 3]);
    let p = fr.pyramids();
    let k = cone(Vec2::new(4.0, 3.0), Vec2::new(28.0, 5.0), 1.0, 1.5, 0.05);
    let r = try_cone_trace(&p, &k, [0.0; 3], &ConeOptions::default()).unwrap();
    assert_eq!(r.coverage, 0.0);
    assert_eq!(r.color, [0.0; 3]);
    // Behind the wall: fully covered.
    let k = cone(Vec2::new(4.0, 3.0), Vec2::new(28.0, 5.0), 25.0, 30.0, 0.05);
    let r = try_cone_trace(&p, &k, [0.0; 3], &ConeOptions::default()).unwrap();
    assert_eq!(r.coverage, 1.0);
}

#[test]
fn anisotropic_stretch_takes_more_samples_along_the_axis() {
    // Horizontal stripes; a vertical cone axis. Stretching along the axis
    // averages across stripes: closer to the mean than the isotropic read.
    let fr = Frame::new(64, 64, 5.0, DepthConvention::Linear, |_, y| {
        let v = ((y / 2) % 2) as f32;
        [v, v, v]
    });
    let p = fr.pyramids();
    let base = ConeOptions {
        max_circles: 1,
        use_visibility: false,
        ..ConeOptions::default()
    };
    let mut k = cone(Vec2::new(20.5, 2.5), Vec2::new(20.5, 28.0), 5.5, 5.5, 0.02);
    k.n_dot_v = 0.2;
    let iso = try_cone_trace(&p, &k, [0.0; 3], &base).unwrap();
    let st = try_cone_trace(
        &p,
        &k,
        [0.0; 3],
        &ConeOptions {
            max_stretch: 8.0,
            ..base
        },
    )
    .unwrap();
    assert!(
        st.fetches >= 4 * iso.fetches,
        "{} {}",
        st.fetches,
        iso.fetches
    );
    assert!(
        (st.color[0] - 0.5).abs() < (iso.color[0] - 0.5).abs(),
        "{:?} {:?}",
        st.color,
        iso.color
    );
    // n_dot_v = 1: no stretch even when allowed.
    k.n_dot_v = 1.0;
    let one = try_cone_trace(
        &p,
        &k,
        [0.0; 3],
        &ConeOptions {
            max_stretch: 8.0,
            ..base
        },
    )
    .unwrap();
    let iso1 = try_cone_trace(&p, &k, [0.0; 3], &base).unwrap();
    assert_eq!(one, iso1);
}

#[test]
fn cone_trace_agrees_across_depth_conventions() {
    let paint = |x: u32, y: u32| [x as f32 / 50.0, y as f32 / 40.0, 0.5];
    let frames: Vec<Frame> = DepthConvention::ALL
        .iter()
        .map(|&c| Frame::new(50, 40, 9.0, c, paint))
        .collect();
    let mut rng = Rng(99);
    for _ in 0..100 {
        let k = cone(
            Vec2::new(rng.f() * 50.0, 20.0 + rng.f() * 20.0),
            Vec2::new(rng.f() * 50.0, rng.f() * 20.0),
            1.5 + rng.f(),
            3.0 + rng.f() * 6.0,
            rng.f() * 0.8,
        );
        let r: Vec<_> = frames
            .iter()
            .map(|f| {
                try_cone_trace(&f.pyramids(), &k, [0.0, 1.0, 0.0], &ConeOptions::default()).unwrap()
            })
            .collect();
        for x in &r[1..] {
            assert!(
                (x.coverage - r[0].coverage).abs() < 2e-3,
                "{x:?} {:?}",
                r[0]
            );
            for c in 0..3 {
                assert!((x.color[c] - r[0].color[c]).abs() < 2e-3);
            }
        }
    }
}

#[test]
fn cone_trace_rejects_bad_input() {
    let fr = Frame::new(16, 16, 5.0, DepthConvention::Linear, |_, _| [1.0; 3]);
    let p = fr.pyramids();
    let good = cone(Vec2::new(2.0, 2.0), Vec2::new(10.0, 3.0), 4.0, 5.0, 0.1);
    let o = ConeOptions::default();
    assert!(try_cone_trace(&p, &good, [0.0; 3], &o).is_ok());
    let bad = [
        Cone {
            apex: Vec2::new(f32::NAN, 0.0),
            ..good
        },
        Cone {
            hit: Vec2::new(0.0, f32::INFINITY),
            ..good
        },
        Cone {
            apex_depth: 0.0,
            ..good
        },
        Cone {
            hit_depth: f32::NAN,
            ..good
        },
        Cone {
            theta: f32::NAN,
            ..good
        },
        Cone { theta: 1.6, ..good },
        Cone {
            theta: -0.1,
            ..good
        },
        Cone {
            n_dot_v: f32::NAN,
            ..good
        },
        Cone {
            apex: Vec2::new(-3e38, 0.0),
            hit: Vec2::new(3e38, 0.0),
            ..good
        },
    ];
    for b in bad {
        assert_eq!(
            try_cone_trace(&p, &b, [0.0; 3], &o),
            Err(Error::InvalidArgument),
            "{b:?}"
        );
    }
    assert_eq!(
        try_cone_trace(&p, &good, [f32::NAN, 0.0, 0.0], &o),
        Err(Error::InvalidArgument)
    );
    for bo in [
        ConeOptions {
            level_bias: f32::NAN,
            ..o
        },
        ConeOptions {
            max_stretch: 0.5,
            ..o
        },
        ConeOptions {
            max_stretch: f32::INFINITY,
            ..o
        },
    ] {
        assert_eq!(
            try_cone_trace(&p, &good, [0.0; 3], &bo),
            Err(Error::InvalidArgument)
        );
    }
    let hz = HiZ::try_new(&fr.hiz, fr.cam, fr.conv).unwrap();
    assert_eq!(
        ConePyramids::try_new(hz, &fr.color[..fr.color.len() - 1], &fr.vis).err(),
        Some(Error::InsufficientSize)
    );
    assert_eq!(
        ConePyramids::try_new(hz, &fr.color, &fr.vis[..3]).err(),
        Some(Error::InsufficientSize)
    );
    // Zero-length axis: one sample at the hit.
    let z = cone(Vec2::new(5.0, 5.0), Vec2::new(5.0, 5.0), 4.0, 5.0, 0.3);
    let r = try_cone_trace(&p, &z, [0.0; 3], &o).unwrap();
    assert_eq!(r.circles, 1);
    assert_eq!(r.color, [1.0; 3]);
    let _ = &fr.depth;
}

#[test]
fn visibility_build_rejects_short_buffers() {
    let fr = Frame::new(16, 8, 5.0, DepthConvention::Linear, |_, _| [1.0; 3]);
    let hz = HiZ::try_new(&fr.hiz, fr.cam, fr.conv).unwrap();
    let n = try_visibility_pyramid_len(16, 8).unwrap();
    let mut v = vec![3.0f32; n];
    assert_eq!(
        try_build_visibility_pyramid(&mut v[..n - 1], &hz),
        Err(Error::InsufficientSize)
    );
    assert_eq!(
        try_build_visibility_level_rows(
            &mut v,
            &fr.vis[..5],
            &hz,
            1,
            RowRange::try_all(4).unwrap()
        ),
        Err(Error::InsufficientSize)
    );
    assert_eq!(
        try_build_visibility_level_rows(&mut v, &fr.vis, &hz, 0, RowRange::try_all(4).unwrap()),
        Err(Error::InvalidArgument)
    );
    assert!(v.iter().all(|&x| x == 3.0));
}

// ------------------------------------------------------------ fades

#[test]
fn each_fade_follows_its_range() {
    let r = FadeRange {
        start: 0.2,
        end: 0.6,
    };
    assert_eq!(r.try_at(0.0), Ok(1.0));
    assert_eq!(r.try_at(0.2), Ok(1.0));
    assert!((r.try_at(0.4).unwrap() - 0.5).abs() < 1e-6);
    assert_eq!(r.try_at(0.6), Ok(0.0));
    assert_eq!(r.try_at(5.0), Ok(0.0));
    assert!(r.try_at(f32::NAN).is_err());
    assert!(FadeRange {
        start: 1.0,
        end: 1.0
    }
    .try_at(0.0)
    .is_err());
    assert!(FadeRange {
        start: f32::NAN,
        end: 1.0
    }
    .try_at(0.0)
    .is_err());

    let (w, h) = (100u32, 50u32);
    let eye = Vec3::Z;
    let center = Vec2::new(50.0, 25.0);
    // Toward camera: a ray reflected back at the eye fades out, one
    // leaving sideways does not.
    let f = Fades {
        toward_camera: Some(FadeRange {
            start: 0.0,
            end: 0.5,
        }),
        ..Fades::default()
    };
    assert_eq!(f.try_factor(Vec3::Z, eye, center, w, h, 1.0), Ok(0.0));
    assert_eq!(f.try_factor(Vec3::X, eye, center, w, h, 1.0), Ok(1.0));
    let d = Vec3::new(0.0, 0.0, 0.25) + Vec3::X * (1.0f32 - 0.0625).sqrt();
    assert!((f.try_factor(d, eye, center, w, h, 1.0).unwrap() - 0.5).abs() < 1e-5);
    // Border: 1 at the center, 0 on the border, half way between.
    let f = Fades {
        border: Some(FadeRange {
            start: 0.8,
            end: 1.0,
        }),
        ..Fades::default()
    };
    assert_eq!(f.try_factor(Vec3::X, eye, center, w, h, 1.0), Ok(1.0));
    assert_eq!(
        f.try_factor(Vec3::X, eye, Vec2::new(100.0, 25.0), w, h, 1.0),
        Ok(0.0)
    );
    assert_eq!(
        f.try_factor(Vec3::X, eye, Vec2::new(50.0, 0.0), w, h, 1.0),
        Ok(0.0)
    );
    assert!(
        (f.try_factor(Vec3::X, eye, Vec2::new(95.0, 25.0), w, h, 1.0)
            .unwrap()
            - 0.5)
            .abs()
            < 1e-5
    );
    // Travel.
    let f = Fades {
        travel: Some(FadeRange {
            start: 2.0,
            end: 6.0,
        }),
        ..Fades::default()
    };
    assert_eq!(f.try_factor(Vec3::X, eye, center, w, h, 1.0), Ok(1.0));
    assert!((f.try_factor(Vec3::X, eye, center, w, h, 5.0).unwrap() - 0.25).abs() < 1e-6);
    assert_eq!(f.try_factor(Vec3::X, eye, center, w, h, 7.0), Ok(0.0));
    // Product, and bad input.
    let all = Fades {
        toward_camera: Some(FadeRange {
            start: 0.0,
            end: 0.5,
        }),
        border: Some(FadeRange {
            start: 0.8,
            end: 1.0,
        }),
        travel: Some(FadeRange {
            start: 2.0,
            end: 6.0,
        }),
    };
    let v = all
        .try_factor(d, eye, Vec2::new(95.0, 25.0), w, h, 5.0)
        .unwrap();
    assert!((v - 0.5 * 0.5 * 0.25).abs() < 1e-5);
    assert!(all.try_factor(Vec3::NAN, eye, center, w, h, 1.0).is_err());
    assert!(all.try_factor(Vec3::X, eye, center, 0, h, 1.0).is_err());
    assert!(all
        .try_factor(Vec3::X, eye, center, w, h, f32::INFINITY)
        .is_err());
    assert_eq!(blend_fade([1.0, 2.0, 3.0], [0.0; 3], 0.5), [0.5, 1.0, 1.5]);
    assert_eq!(blend_fade([1.0, 2.0, 3.0], [7.0; 3], 0.0), [7.0; 3]);
}

// ------------------------------------------------------------ multi-ray

#[test]
fn cone_directions_are_uniform_in_the_cap() {
    let axis = Vec3::new(0.3, -0.5, 0.8).normalize();
    for &theta in &[1e-4f32, 0.1, 0.7, 89f32.to_radians()] {
        let n = 4096u32;
        let mut mean_cos = 0.0f64;
        for i in 0..n {
            let xi = Vec2::new(
                i as f32 / n as f32,
                i.reverse_bits() as f32 / 4_294_967_296.0,
            );
            let d = cone_ray_direction(axis, theta, xi);
            assert!((d.length() - 1.0).abs() < 1e-5);
            let c = d.dot(axis) as f64;
            assert!(c >= (theta as f64).cos() - 1e-5, "{theta}");
            mean_cos += c;
        }
        mean_cos /= n as f64;
        // Uniform over the cap: E[cos] = (1 + cos theta) / 2.
        let expect = 0.5 * (1.0 + (theta as f64).cos());
        assert!(
            (mean_cos - expect).abs() < 1e-3,
            "{theta}: {mean_cos} {expect}"
        );
    }
    assert_eq!(phong_lobe_weight(-0.1, 3.0), 0.0);
    assert_eq!(phong_lobe_weight(1.0, 1e6), 1.0);
    assert!((phong_lobe_weight(0.5, 2.0) - 0.25).abs() < 1e-7);
}

/// Fuzz finding F18: the weighted mean of colors near `f32::MAX` overflowed
/// an f32 sum (weights up to `(power + 1) / (2 pi)`) to `+inf`.
#[test]
fn multiray_mean_of_huge_colors_is_finite() {
    let c = [3.0e38f32, 1.0, 0.0];
    let fr = Frame::new(48, 32, 6.0, DepthConvention::ReversedZ, |_, _| c);
    let p = fr.pyramids();
    let ray = Ray {
        origin: Vec3::new(0.0, -0.9, -3.0),
        dir: Vec3::new(0.0, 0.3, -1.0).normalize(),
    };
    let opts = MultiRayOptions {
        rays: 16,
        rotation: Vec2::new(0.3, 0.7),
        hiz: HiZOptions::default(),
    };
    let r = try_multiray(
        &p,
        Thickness::Constant(f32::INFINITY),
        ray,
        Vec3::Y,
        100.0,
        0.1,
        100.0,
        &opts,
        |_| c,
    )
    .unwrap();
    assert!(r.hits > 0);
    assert!(r.color.iter().all(|v| v.is_finite()), "{:?}", r.color);
    assert!((r.color[0] / c[0] - 1.0).abs() < 1e-6, "{:?}", r.color);
}

/// Fuzz finding F19: a pyramid color near `f32::MAX` and a fallback of the
/// other sign overflowed the f32 color difference; the result, a convex
/// combination of the two, is finite and equals the f64 combination.
#[test]
fn cone_trace_of_huge_colors_against_a_huge_fallback_is_finite() {
    let c = [3.0e38f32, -3.0e38, 1.0];
    let fallback = [-3.0e38f32, 3.0e38, 0.5];
    let fr = Frame::new(48, 32, 6.0, DepthConvention::ReversedZ, |_, _| c);
    let p = fr.pyramids();
    for normalize in [false, true] {
        let opts = ConeOptions {
            normalize,
            max_stretch: 4.0,
            ..ConeOptions::default()
        };
        let mut k = cone(Vec2::new(20.0, 24.0), Vec2::new(20.0, 10.0), 2.0, 5.0, 0.3);
        k.n_dot_v = 0.4;
        let r = try_cone_trace(&p, &k, fallback, &opts).unwrap();
        assert!(r.color.iter().all(|v| v.is_finite()), "{:?}", r.color);
        assert!(r.coverage > 0.0);
        // Every sample reads `c`: the result is fallback + coverage (c -
        // fallback), or `c` itself when normalized.
        let w = if normalize {
            1.0
        } else {
            f64::from(r.coverage)
        };
        for i in 0..3 {
            let want = f64::from(fallback[i]) + w * (f64::from(c[i]) - f64::from(fallback[i]));
            let tol = 1e-6 * want.abs().max(1.0);
            assert!(
                (f64::from(r.color[i]) - want).abs() <= tol,
                "{i}: {} vs {want}",
                r.color[i]
            );
        }
    }
}

#[test]
fn multiray_uniform_scene_and_bad_input() {
    let c = [0.4f32, 0.5, 0.6];
    for conv in DepthConvention::ALL {
        let fr = Frame::new(48, 32, 6.0, conv, |_, _| c);
        let p = fr.pyramids();
        // From a point on the floor, reflecting toward the wall.
        let origin = Vec3::new(0.0, -0.9, -3.0);
        let ray = Ray {
            origin,
            dir: Vec3::new(0.0, 0.3, -1.0).normalize(),
        };
        let opts = MultiRayOptions {
            rays: 16,
            rotation: Vec2::new(0.3, 0.7),
            hiz: HiZOptions::default(),
        };
        let r = try_multiray(
            &p,
            Thickness::Constant(f32::INFINITY),
            ray,
            Vec3::Y,
            100.0,
            0.1,
            50.0,
            &opts,
            |_| c,
        )
        .unwrap();
        assert_eq!(r.traced, 16);
        assert!(r.hits > 0, "{conv:?}");
        for k in 0..3 {
            assert!((r.color[k] - c[k]).abs() < 1e-6);
        }
        // A different fallback: rays that hit read the wall color; the
        // color is between the two.
        let r2 = try_multiray(
            &p,
            Thickness::Constant(f32::INFINITY),
            ray,
            Vec3::Y,
            100.0,
            0.1,
            50.0,
            &opts,
            |_| [0.0; 3],
        )
        .unwrap();
        assert!(r2.color[0] <= c[0] + 1e-6 && r2.color[0] >= 0.0);
        assert_eq!(r2.hits, r.hits);
        // The fallback's share of the lobe: the mean is linear in the
        // fallback, so a white fallback adds exactly that share (f64 sums).
        // A narrow cone hits the wall with every ray, a wide one not.
        let mut partial = false;
        for theta in [0.1, 1.2] {
            let run = |fb: [f32; 3]| {
                let thick = Thickness::Constant(f32::INFINITY);
                try_multiray(&p, thick, ray, Vec3::Y, 100.0, theta, 50.0, &opts, |_| fb).unwrap()
            };
            let (black, white) = (run([0.0; 3]), run([1.0; 3]));
            assert!((0.0..=1.0).contains(&black.fallback_weight), "{black:?}");
            assert_eq!(black.fallback_weight, white.fallback_weight);
            partial |= black.fallback_weight > 0.0 && black.fallback_weight < 1.0;
            for k in 0..3 {
                assert!((white.color[k] - black.color[k] - black.fallback_weight).abs() < 1e-6);
            }
        }
        assert!(partial, "{conv:?}");
        // No ray above the surface: all fallback.
        let down = try_multiray(
            &p,
            Thickness::Constant(f32::INFINITY),
            ray,
            -ray.dir,
            100.0,
            0.1,
            50.0,
            &opts,
            |_| c,
        )
        .unwrap();
        assert_eq!((down.traced, down.fallback_weight), (0, 1.0));
        // Bad input.
        let t = Thickness::Constant(1.0);
        assert!(try_multiray(
            &p,
            t,
            ray,
            Vec3::Y,
            100.0,
            0.1,
            50.0,
            &MultiRayOptions { rays: 0, ..opts },
            |_| c
        )
        .is_err());
        assert!(try_multiray(&p, t, ray, Vec3::NAN, 100.0, 0.1, 50.0, &opts, |_| c).is_err());
        assert!(try_multiray(&p, t, ray, Vec3::Y, f32::NAN, 0.1, 50.0, &opts, |_| c).is_err());
        assert!(try_multiray(&p, t, ray, Vec3::Y, 100.0, f32::NAN, 50.0, &opts, |_| c).is_err());
        assert!(try_multiray(&p, t, ray, Vec3::Y, 100.0, 0.1, -1.0, &opts, |_| c).is_err());
        assert!(try_multiray(
            &p,
            t,
            Ray {
                origin: Vec3::NAN,
                dir: Vec3::X
            },
            Vec3::Y,
            100.0,
            0.1,
            1.0,
            &opts,
            |_| c
        )
        .is_err());
    }
}

#[test]
fn view_space_size_widens_the_cone_for_rays_into_depth() {
    // Vertical stripes of 2 pixels; a short screen axis that travels far in
    // depth: the seed's screen triangle reads one stripe, the view-space
    // size (travel) reads a wide footprint near the stripes' mean.
    let fr = Frame::new(64, 64, 5.0, DepthConvention::Linear, |x, _| {
        let v = ((x / 2) % 2) as f32;
        [v, v, v]
    });
    let p = fr.pyramids();
    let base = cone(Vec2::new(30.5, 12.0), Vec2::new(30.5, 8.0), 5.0, 5.0, 0.1);
    let opts = ConeOptions {
        max_circles: 1,
        use_visibility: false,
        ..ConeOptions::default()
    };
    let screen = try_cone_trace(&p, &base, [0.0; 3], &opts).unwrap();
    let view = try_cone_trace(
        &p,
        &Cone {
            travel: 6.0,
            ..base
        },
        [0.0; 3],
        &opts,
    )
    .unwrap();
    // f = 64 / (2 tan 30deg) = 55.4 px; r = f 6 tan(0.1) / 5 = 6.7 px over
    // a 4 px axis.
    assert!((screen.color[0] - 0.5).abs() > 0.3, "{:?}", screen.color);
    assert!((view.color[0] - 0.5).abs() < 0.15, "{:?}", view.color);
    // travel = 0 is the seed's triangle exactly.
    assert_eq!(
        try_cone_trace(
            &p,
            &Cone {
                travel: 0.0,
                ..base
            },
            [0.0; 3],
            &opts
        )
        .unwrap(),
        screen
    );
}

/// Issue 12: the cone pyramids carry what they were built for; bound to
/// another frame's Hi-Z (size or camera), or unbuilt, they are refused.
#[test]
fn cone_pyramids_refuse_another_frame() {
    let conv = DepthConvention::ReversedZ;
    let a = Frame::new(24, 16, 8.0, conv, |_, _| [0.5; 3]);
    let b = Frame::new(12, 8, 8.0, conv, |_, _| [0.5; 3]);
    let ha = HiZ::try_new(&a.hiz, a.cam, conv).unwrap();
    assert!(ConePyramids::try_new(ha, &a.color, &a.vis).is_ok());
    assert_eq!(
        a.vis.len(),
        HiZLayout::try_new(24, 16).unwrap().len() + VISIBILITY_STAMP_LEN
    );
    // b's (smaller) pyramids padded to a's length: long enough, not a's.
    let mut color_b = b.color.clone();
    color_b.resize(a.color.len(), [0.0; 3]);
    let mut vis_b = b.vis.clone();
    vis_b.resize(a.vis.len(), 0.0);
    assert_eq!(
        ConePyramids::try_new(ha, &color_b, &a.vis).err(),
        Some(Error::InvalidArgument)
    );
    assert_eq!(
        ConePyramids::try_new(ha, &a.color, &vis_b).err(),
        Some(Error::InvalidArgument)
    );
    // The same size, another camera: a visibility pyramid of the moved
    // camera's Hi-Z is refused for this Hi-Z.
    let moved = Camera::try_look_at(
        Vec3::new(0.3, 1.0, 3.0),
        Vec3::ZERO,
        Vec3::Y,
        1.0,
        0.1,
        FAR,
        24,
        16,
    )
    .unwrap();
    let mut vis_moved = a.vis.clone();
    PyramidStamp::of(&moved).try_write(&mut vis_moved).unwrap();
    assert_eq!(
        ConePyramids::try_new(ha, &a.color, &vis_moved).err(),
        Some(Error::InvalidArgument)
    );
    // Never built.
    let blank_c = vec![[0.0f32; 3]; a.color.len()];
    assert_eq!(
        ConePyramids::try_new(ha, &blank_c, &a.vis).err(),
        Some(Error::InvalidArgument)
    );
    // Short: the stamp is part of the length.
    assert_eq!(
        ConePyramids::try_new(ha, &a.color[..a.color.len() - 1], &a.vis).err(),
        Some(Error::InsufficientSize)
    );
    // No visibility pyramid: multi-ray and use_visibility off work, a
    // trace with use_visibility on is refused.
    let pyr = ConePyramids::try_new(ha, &a.color, &[]).unwrap();
    let cone = Cone {
        apex: Vec2::new(12.0, 12.0),
        hit: Vec2::new(12.0, 4.0),
        theta: 0.1,
        apex_depth: 2.0,
        hit_depth: 6.0,
        n_dot_v: 0.7,
        travel: 0.0,
    };
    let on = ConeOptions::default();
    assert!(on.use_visibility);
    assert_eq!(
        try_cone_trace(&pyr, &cone, [0.0; 3], &on).err(),
        Some(Error::InvalidArgument)
    );
    let off = ConeOptions {
        use_visibility: false,
        ..on
    };
    let full = ConePyramids::try_new(ha, &a.color, &a.vis).unwrap();
    assert_eq!(
        try_cone_trace(&pyr, &cone, [0.0; 3], &off).unwrap(),
        try_cone_trace(&full, &cone, [0.0; 3], &off).unwrap()
    );
}

/// Fuzz finding F13: a cone stretched by a huge `max_stretch` (2.3e21,
/// with `n_dot_v <= 0`, so the stretch is the maximum) samples the pyramid
/// at positions ~1e21 px outside the image, whose integer cell saturated to
/// `i64::MAX`; `cell + 1` overflowed (a panic with debug assertions). The
/// trace now returns a finite result.
#[test]
fn cone_stretched_far_outside_the_image_is_finite() {
    let fr = Frame::new(32, 24, 5.0, DepthConvention::ZeroToOne, |_, _| [0.5; 3]);
    let p = fr.pyramids();
    for max_stretch in [2.334_960_3e21f32, 1e30, f32::MAX] {
        let opts = ConeOptions {
            max_stretch,
            use_visibility: true,
            ..ConeOptions::default()
        };
        let k = Cone {
            apex: Vec2::new(2.4e-35, 0.9998169),
            apex_depth: 11.413258,
            hit: Vec2::new(0.9123827, 0.153048),
            hit_depth: 3.4544716,
            theta: 0.6573541,
            n_dot_v: -1.1754944e-38,
            travel: 1.0608072,
        };
        let r = try_cone_trace(&p, &k, [-0.05, 0.0, 0.0], &opts).unwrap();
        assert!(
            r.color.iter().all(|c| c.is_finite()) && (0.0..=1.0).contains(&r.coverage),
            "{max_stretch}: {r:?}"
        );
    }
}

/// `try_multiray` traces its rays in batches (the AVX2 ray stream where
/// the CPU has it); its result is the one of tracing each ray on its own
/// with `try_trace_hiz` and weighting them in order, bit for bit: ray
/// counts below, at and across the batch size (32), rays below the surface
/// skipped, a painted wall so that hits and misses weigh differently.
#[test]
fn multiray_equals_its_rays_traced_one_by_one() {
    let paint = |x: u32, y: u32| [x as f32 / 48.0, y as f32 / 32.0, 0.25];
    let fallback = |d: Vec3| [d.x.abs(), d.y.abs(), 0.5];
    let (mut all_hits, mut all_missed, mut all_skipped) = (0u32, 0u32, 0u32);
    for conv in DepthConvention::ALL {
        let fr = Frame::new(48, 32, 6.0, conv, paint);
        let p = fr.pyramids();
        for (origin, dir, normal) in [
            (
                Vec3::new(0.0, -0.9, -3.0),
                Vec3::new(0.0, 0.3, -1.0),
                Vec3::Y,
            ),
            (
                Vec3::new(0.5, -0.9, -2.0),
                Vec3::new(0.4, 0.05, -1.0),
                Vec3::Y,
            ),
            (
                Vec3::new(-0.5, 0.0, -2.0),
                Vec3::new(-0.3, 0.2, -1.0),
                Vec3::Z,
            ),
        ] {
            let ray = Ray {
                origin,
                dir: dir.normalize(),
            };
            for rays in [1u32, 7, 8, 16, 31, 32, 33, 49, 100] {
                for (theta, th) in [(0.1f32, 0.3f32), (0.6, f32::INFINITY), (1.2, 0.0)] {
                    let opts = MultiRayOptions {
                        rays,
                        rotation: Vec2::new(0.3, 0.7),
                        hiz: HiZOptions::default(),
                    };
                    let thick = Thickness::Constant(th);
                    let r =
                        try_multiray(&p, thick, ray, normal, 40.0, theta, 20.0, &opts, fallback)
                            .unwrap();
                    // By hand, one ray at a time.
                    let axis = ray.dir.normalize();
                    let (mut sum, mut wsum, mut missed) = ([0.0f64; 3], 0.0f64, 0.0f64);
                    let (mut traced, mut hits, mut iterations) = (0u32, 0u32, 0u32);
                    for i in 0..rays {
                        let xi = refl_core::lobe::hammersley(i, rays) + opts.rotation;
                        let d = cone_ray_direction(axis, theta, xi - xi.floor());
                        if d.dot(normal) <= 0.0 {
                            continue;
                        }
                        traced += 1;
                        let one = Ray { origin, dir: d };
                        let t =
                            refl_core::try_trace_hiz(p.hiz(), thick, one, 40.0, &opts.hiz).unwrap();
                        iterations += t.work().iterations;
                        let w = f64::from(phong_lobe_weight(d.dot(axis), 20.0));
                        let c = match t.hit() {
                            Some(h) => {
                                hits += 1;
                                let x = (h.pixel.x.max(0.0) as usize).min(47);
                                let y = (h.pixel.y.max(0.0) as usize).min(31);
                                fr.color[y * 48 + x]
                            }
                            None => {
                                missed += w;
                                fallback(d)
                            }
                        };
                        for k in 0..3 {
                            sum[k] += w * f64::from(c[k]);
                        }
                        wsum += w;
                    }
                    let at = format!("{conv:?} {origin} rays {rays} theta {theta} th {th}");
                    all_hits += hits;
                    all_missed += traced - hits;
                    all_skipped += rays - traced;
                    assert_eq!(
                        (r.traced, r.hits, r.iterations),
                        (traced, hits, iterations),
                        "{at}"
                    );
                    if wsum > 0.0 {
                        let want = [0, 1, 2].map(|k| (sum[k] / wsum) as f32);
                        assert_eq!(r.color.map(f32::to_bits), want.map(f32::to_bits), "{at}");
                        assert_eq!(
                            r.fallback_weight.to_bits(),
                            ((missed / wsum) as f32).to_bits(),
                            "{at}"
                        );
                    } else {
                        assert_eq!(r.color, fallback(axis), "{at}");
                    }
                }
            }
        }
    }
    assert!(
        all_hits > 100 && all_missed > 100 && all_skipped > 10,
        "hits {all_hits}, misses {all_missed}, skipped {all_skipped}"
    );
}
