//! Image views: validation, bounds, row bands.

use proptest::prelude::*;

mod common;
use refl_core::image::try_required_len;
use refl_core::{Error, ImageView, ImageViewMut, RowRange};

#[test]
fn required_len_validates_and_never_overflows() {
    assert_eq!(try_required_len(1, 1, 1), Ok(1));
    assert_eq!(try_required_len(3, 2, 4), Ok(7));
    assert_eq!(try_required_len(16384, 16384, 16384), Ok(16384 * 16384));
    assert_eq!(try_required_len(0, 4, 4), Err(Error::InvalidArgument));
    assert_eq!(try_required_len(4, 0, 4), Err(Error::InvalidArgument));
    assert_eq!(try_required_len(5, 4, 4), Err(Error::InvalidArgument));
    // u32::MAX x u32::MAX: 64-bit arithmetic, no wrap-around.
    let big = try_required_len(u32::MAX, u32::MAX, u32::MAX);
    if usize::BITS >= 64 {
        assert_eq!(big, Ok(u32::MAX as usize * u32::MAX as usize));
    } else {
        assert_eq!(big, Err(Error::InvalidArgument));
    }
}

#[test]
fn views_reject_short_buffers_and_bad_sizes() {
    let data = [0f32; 11];
    assert_eq!(ImageView::try_new(&data, 3, 3, 4).map(|v| v.width()), Ok(3));
    assert_eq!(
        ImageView::try_new(&data, 4, 3, 4).map(|v| v.width()),
        Err(Error::InsufficientSize)
    );
    assert_eq!(
        ImageView::try_new(&data, 0, 3, 4).map(|v| v.width()),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        ImageView::try_new(&data, u32::MAX, u32::MAX, u32::MAX).map(|v| v.width()),
        Err(Error::InsufficientSize)
    );
    let mut m = [0u32; 3];
    assert!(ImageViewMut::try_new(&mut m, 2, 2, 2).is_err());
}

#[test]
fn accessors_are_bounds_checked_and_stride_aware() {
    // 3x2 image in a stride-4 buffer; the padding holds 99.
    let data = [0, 1, 2, 99, 10, 11, 12];
    let v = ImageView::try_new(&data, 3, 2, 4).unwrap();
    assert_eq!(v.get(2, 1), Some(12));
    assert_eq!(v.get(3, 0), None);
    assert_eq!(v.get(0, 2), None);
    assert_eq!(v.row(1), Some(&data[4..7]));
    assert_eq!(v.row(2), None);
    assert_eq!(v.get_clamped(-5, 9), 10);
    assert_eq!(v.get_clamped(7, -1), 2);
}

#[test]
fn split_bands_are_disjoint_and_keep_global_coordinates() {
    let mut buf = [0u8; 5 * 6];
    let img = ImageViewMut::try_new(&mut buf, 5, 6, 5).unwrap();
    let (mut top, rest) = img.try_split_at_row(2).unwrap();
    let (mut mid, mut bottom) = rest.try_split_at_row(5).unwrap();
    assert_eq!(top.owned_rows(), RowRange::try_new(0, 2, 6).ok());
    assert_eq!(mid.owned_rows(), RowRange::try_new(2, 5, 6).ok());
    assert!(top.get_mut(0, 2).is_none());
    assert!(mid.get_mut(0, 1).is_none());
    top.fill(1);
    mid.fill(2);
    *bottom.get_mut(4, 5).unwrap() = 3;
    assert!(bottom.as_view().is_none());
    // A split outside the band is refused and hands the view back.
    let (e, bottom) = bottom.try_split_at_row(1).unwrap_err();
    assert_eq!(e, Error::InvalidArgument);
    assert_eq!(bottom.get(4, 5), Some(3));
    assert_eq!(&buf[..10], &[1; 10]);
    assert_eq!(&buf[10..25], &[2; 15]);
    assert_eq!(buf[29], 3);
}

#[test]
fn row_range_validation() {
    assert!(RowRange::try_new(0, 1, 1).is_ok());
    assert_eq!(RowRange::try_new(1, 1, 4), Err(Error::InvalidArgument));
    assert_eq!(RowRange::try_new(3, 2, 4), Err(Error::InvalidArgument));
    assert_eq!(RowRange::try_new(0, 5, 4), Err(Error::InvalidArgument));
    assert_eq!(RowRange::try_all(0), Err(Error::InvalidArgument));
}

proptest! {
    #![proptest_config(common::proptest_config(256))]
    #[test]
    fn prop_bands_partition_the_range(start in 0u32..50, len in 1u32..200, count in 1u32..64) {
        let r = RowRange::try_new(start, start + len, start + len).unwrap();
        let mut next = start;
        for i in 0..count {
            if let Some(b) = r.band(i, count) {
                prop_assert_eq!(b.start(), next);
                prop_assert!(b.len() == len / count || b.len() == len / count + 1);
                next = b.end();
            }
        }
        prop_assert_eq!(next, start + len);
        prop_assert!(r.band(count, count).is_none());
    }
}

/// A camera for the depth conversions (only its near and far planes are
/// used).
fn depth_camera(far: f32) -> refl_core::Camera {
    refl_core::Camera::try_look_at(
        refl_core::glam::Vec3::ZERO,
        -refl_core::glam::Vec3::Z,
        refl_core::glam::Vec3::Y,
        1.0,
        0.25,
        far,
        5,
        4,
    )
    .unwrap()
}

#[test]
fn convert_depth_converts_owned_rows_only_and_matches_f64() {
    use refl_core::image::{convert_depth_in_place, try_convert_depth};
    use refl_core::DepthConvention::{Linear, ReversedZ, ZeroToOne};
    let (w, h, stride) = (5u32, 4u32, 7u32);
    let len = try_required_len(w, h, stride).unwrap();
    for far in [40.0f32, f32::INFINITY] {
        let cam = depth_camera(far);
        let src: Vec<f32> = (0..len)
            .map(|i| {
                if i == 8 {
                    f32::NAN
                } else {
                    0.3 + i as f32 * 0.7
                }
            })
            .collect();
        let sv = ImageView::try_new(&src, w, h, stride).unwrap();
        for to in [ZeroToOne, ReversedZ] {
            let mut dst = vec![-1.0f32; len];
            {
                let v = ImageViewMut::try_new(&mut dst, w, h, stride).unwrap();
                // Only rows 1..3 are owned by the band converted.
                let (_, rest) = v.try_split_at_row(1).unwrap();
                let (mut band, _) = rest.try_split_at_row(3).unwrap();
                try_convert_depth(&mut band, &sv, &cam, Linear, to).unwrap();
            }
            for y in 0..h {
                for x in 0..stride {
                    let i = (y * stride + x) as usize;
                    let Some(&d) = dst.get(i) else { continue };
                    if !(1..3).contains(&y) || x >= w {
                        assert_eq!(d, -1.0, "texel ({x}, {y}) outside the band");
                        continue;
                    }
                    let z = f64::from(src[i]);
                    if z.is_nan() {
                        assert!(d.is_nan());
                        continue;
                    }
                    // f64 closed forms of the two conventions.
                    let (n, f) = (0.25f64, f64::from(far));
                    let want = match (to, f.is_finite()) {
                        (ZeroToOne, true) => f * (z - n) / (z * (f - n)),
                        (ZeroToOne, false) => 1.0 - n / z,
                        (_, true) => n * (f - z) / (z * (f - n)),
                        (_, false) => n / z,
                    };
                    assert!(
                        (f64::from(d) - want).abs() <= 1e-6,
                        "{to:?} far {far}: {d} vs {want}"
                    );
                    assert_eq!(d, cam.encode_depth(src[i], to));
                }
            }
            // In place equals out of place, texel for texel.
            let mut inplace = src.clone();
            {
                let mut v = ImageViewMut::try_new(&mut inplace, w, h, stride).unwrap();
                convert_depth_in_place(&mut v, &cam, Linear, to);
            }
            let mut out = src.clone();
            {
                let mut v = ImageViewMut::try_new(&mut out, w, h, stride).unwrap();
                try_convert_depth(&mut v, &sv, &cam, Linear, to).unwrap();
            }
            assert_eq!(
                inplace.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                out.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
            );
        }
    }
    // Different sizes: refused, nothing written.
    let cam = depth_camera(40.0);
    let src = vec![1.0f32; 20];
    let sv = ImageView::try_new(&src, 5, 4, 5).unwrap();
    let mut dst = vec![-1.0f32; 15];
    let mut v = ImageViewMut::try_new(&mut dst, 5, 3, 5).unwrap();
    assert_eq!(
        try_convert_depth(&mut v, &sv, &cam, Linear, ZeroToOne),
        Err(Error::InvalidArgument)
    );
    assert!(dst.iter().all(|&d| d == -1.0));
}
