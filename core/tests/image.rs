//! Image views: validation, bounds, row bands.

use proptest::prelude::*;

mod common;
use refl_core::image::required_len;
use refl_core::{Error, ImageView, ImageViewMut, RowRange};

#[test]
fn required_len_validates_and_never_overflows() {
    assert_eq!(required_len(1, 1, 1), Ok(1));
    assert_eq!(required_len(3, 2, 4), Ok(7));
    assert_eq!(required_len(16384, 16384, 16384), Ok(16384 * 16384));
    assert_eq!(required_len(0, 4, 4), Err(Error::InvalidArgument));
    assert_eq!(required_len(4, 0, 4), Err(Error::InvalidArgument));
    assert_eq!(required_len(5, 4, 4), Err(Error::InvalidArgument));
    // u32::MAX x u32::MAX: 64-bit arithmetic, no wrap-around.
    let big = required_len(u32::MAX, u32::MAX, u32::MAX);
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
    let (mut top, rest) = img.split_at_row(2).unwrap();
    let (mut mid, mut bottom) = rest.split_at_row(5).unwrap();
    assert_eq!(top.owned_rows(), RowRange::try_new(0, 2, 6).ok());
    assert_eq!(mid.owned_rows(), RowRange::try_new(2, 5, 6).ok());
    assert!(top.get_mut(0, 2).is_none());
    assert!(mid.get_mut(0, 1).is_none());
    top.fill(1);
    mid.fill(2);
    *bottom.get_mut(4, 5).unwrap() = 3;
    assert!(bottom.as_view().is_none());
    // A split outside the band is refused and hands the view back.
    let (e, bottom) = bottom.split_at_row(1).unwrap_err();
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
