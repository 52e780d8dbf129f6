//! The color and visibility pyramids a cone trace reads (seed 004
//! Sec. 4.4.4 / 4.5.4 pre-convolution, Sec. 4.4.2 / 4.5.2
//! pre-integration): their lengths and stamps, the normalized Gaussian
//! convolution weights, and the whole and row-band builds.

use super::ColorTexel;
use crate::hiz::{try_pyramid_len, HiZ, HiZLayout, PyramidStamp};
use crate::{Error, ImageView, RowRange};

/// Default Gaussian standard deviation of the pre-convolution, in texels of
/// the finer level. The seed's 7-tap weights (Sec. 4.5.4: 0.001, 0.028,
/// 0.233, 0.474, ...) correspond to about 0.84; 1.0 suppresses more
/// aliasing on the halving step.
pub const DEFAULT_SIGMA: f32 = 1.0;

/// Half-width of the pre-convolution kernel in finer texels (the seed's
/// 7x7 kernel has 3).
pub const KERNEL_RADIUS: i64 = 3;

// ------------------------------------------------------------ pyramids

/// Texels of the color pyramid of a `width x height` frame: the levels
/// (same layout as the Hi-Z pyramid, [`HiZLayout`]), then
/// [`COLOR_STAMP_TEXELS`] for its [`PyramidStamp`].
///
/// # Errors
/// As [`HiZLayout::try_new`].
pub fn try_color_pyramid_len(width: u32, height: u32) -> Result<usize, Error> {
    try_pyramid_len::<ColorTexel>(width, height)
}

/// Floats of the visibility pyramid of a `width x height` frame: the
/// levels (same layout as the Hi-Z pyramid), then
/// [`VISIBILITY_STAMP_LEN`] for its [`PyramidStamp`].
///
/// # Errors
/// As [`HiZLayout::try_new`].
pub fn try_visibility_pyramid_len(width: u32, height: u32) -> Result<usize, Error> {
    try_pyramid_len::<f32>(width, height)
}

/// Texels after the color pyramid's last level that hold its stamp (the
/// frame size: the color image has no camera).
pub const COLOR_STAMP_TEXELS: usize = <ColorTexel as crate::hiz::PyramidTexel>::STAMP_TEXELS;

/// Floats after the visibility pyramid's last level that hold its stamp
/// (the size and camera of the Hi-Z it was built from).
pub const VISIBILITY_STAMP_LEN: usize = <f32 as crate::hiz::PyramidTexel>::STAMP_TEXELS;

/// Stamps a row-band-built color pyramid of a `width x height` frame
/// ([`try_build_color_level0_rows`], [`try_build_color_level_rows`]; the
/// whole build [`try_build_color_pyramid`] does it itself).
///
/// # Errors
/// [`Error::InsufficientSize`] if `dst` is shorter than
/// [`try_color_pyramid_len`]; [`Error::InvalidArgument`] for a zero size.
pub fn try_stamp_color_pyramid(
    dst: &mut [ColorTexel],
    width: u32,
    height: u32,
) -> Result<(), Error> {
    PyramidStamp::of_size(width, height).try_write(dst)
}

/// Stamps a row-band-built visibility pyramid of `hiz`
/// ([`try_build_visibility_level0_rows`], [`try_build_visibility_level_rows`];
/// the whole build [`try_build_visibility_pyramid`] does it itself).
///
/// # Errors
/// [`Error::InsufficientSize`] if `dst` is shorter than
/// [`try_visibility_pyramid_len`].
pub fn try_stamp_visibility_pyramid(dst: &mut [f32], hiz: &HiZ<'_>) -> Result<(), Error> {
    PyramidStamp::of(hiz.camera()).try_write(dst)
}

fn validate_sigma(sigma: f32) -> Result<(), Error> {
    if sigma > 0.0 && sigma.is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidArgument)
    }
}

pub(super) fn finite3(c: ColorTexel) -> bool {
    c[0].is_finite() && c[1].is_finite() && c[2].is_finite()
}

/// Copies rows `rows` of the frame `color` into `band` (level 0 of the color
/// pyramid, row stride = width).
///
/// # Errors
/// [`Error::InvalidArgument`] if `rows` exceed the height or a texel is not
/// finite; [`Error::InsufficientSize`] if `band` is too short. Nothing is
/// written on error.
///
/// # Panics
/// Never.
pub fn try_build_color_level0_rows(
    band: &mut [ColorTexel],
    color: &ImageView<'_, ColorTexel>,
    rows: RowRange,
) -> Result<(), Error> {
    if rows.end() > color.height() {
        return Err(Error::InvalidArgument);
    }
    let w = color.width() as usize;
    if band.len() < rows.len() as usize * w {
        return Err(Error::InsufficientSize);
    }
    for y in rows.rows() {
        if let Some(src) = color.row(y) {
            if !src.iter().all(|&c| finite3(c)) {
                return Err(Error::InvalidArgument);
            }
        }
    }
    for (dst, y) in band.chunks_exact_mut(w).zip(rows.rows()) {
        if let Some(src) = color.row(y) {
            dst.copy_from_slice(src);
        }
    }
    Ok(())
}

/// Normalized Gaussian weight of finer texel `t` (center `t + 0.5`) for a
/// coarse texel whose footprint center is `c`, unnormalized.
#[inline]
fn gauss(t: i64, c: f32, inv_two_sigma2: f32) -> f32 {
    let d = t as f32 + 0.5 - c;
    libm::expf(-d * d * inv_two_sigma2)
}

/// The normalized 1D weights of the pre-convolution for coarse texel `i`
/// along an axis (`coarse` texels over `fine` finer texels): taps
/// `first..first + n` of the finer level (clamped to the edge when
/// fetched), Gaussian of standard deviation `sigma` centered on the
/// footprint of `i` (`[2i, 2i + 2)`, the last texel reaching the finer
/// edge, as in [`crate::hiz`]). The weights are divided by their sum and
/// rounded to multiples of `2^-24`, the rest going to the largest, so that
/// they sum to exactly 1 in f32 (Sec. 4.5.4: "weights must equal 1.0 when
/// summed").
///
/// Returns `(first, n, weights)`; `n <= 2 * KERNEL_RADIUS + 3`.
pub fn convolution_weights(i: u32, coarse: u32, fine: u32, sigma: f32) -> (i64, usize, [f32; 9]) {
    let lo = 2 * i64::from(i);
    let hi = if i + 1 >= coarse {
        i64::from(fine)
    } else {
        lo + 2
    };
    let c = (lo + hi) as f32 * 0.5;
    let first = lo - KERNEL_RADIUS;
    let last = hi - 1 + KERNEL_RADIUS;
    let n = ((last - first + 1) as usize).min(9);
    let inv = 0.5 / (sigma * sigma);
    let mut w = [0.0f32; 9];
    let mut sum = 0.0f32;
    for (k, wk) in w.iter_mut().enumerate().take(n) {
        *wk = gauss(first + k as i64, c, inv);
        sum += *wk;
    }
    // Quantize to multiples of 2^-24 and give the rounding rest to the
    // largest weight: the integers sum to 2^24, and every partial sum of
    // such dyadic weights (at most 2^24 units) is exact in f32, so the sum
    // is exactly 1 in any order.
    const UNIT: f32 = 16_777_216.0;
    let mut q = [0u32; 9];
    let (mut big, mut total) = (0, 0u32);
    for k in 0..n {
        q[k] = libm::roundf(w[k] / sum * UNIT) as u32;
        total += q[k];
        if q[k] > q[big] {
            big = k;
        }
    }
    q[big] = (q[big] + (1 << 24)).saturating_sub(total);
    for k in 0..n {
        w[k] = q[k] as f32 / UNIT;
    }
    (first, n, w)
}

/// Builds rows `rows` of color level `level >= 1` from the complete level
/// `level - 1` (seed 004 Sec. 4.4.4 / 4.5.4: separable normalized Gaussian,
/// then half size): texel `(i, j)` is `sum_u sum_v wx(u) wy(v) finer(u, v)`
/// with the weights of [`convolution_weights`] (edge texels clamped). The
/// sum is formed as `c0 + sum w (finer - c0)`, `c0` the finer texel under
/// the footprint's corner, so a constant image stays exactly constant.
///
/// # Errors
/// [`Error::InvalidArgument`] for `level` 0 or past the last level, rows
/// past the level's height, or `sigma` not finite and positive;
/// [`Error::InsufficientSize`] if `finer` or `band` is too short. Nothing is
/// written on error.
///
/// # Panics
/// Never.
pub fn try_build_color_level_rows(
    band: &mut [ColorTexel],
    finer: &[ColorTexel],
    layout: &HiZLayout,
    level: u32,
    rows: RowRange,
    sigma: f32,
) -> Result<(), Error> {
    validate_sigma(sigma)?;
    let (f, c) = layout.try_band_levels(level, rows, finer.len(), band.len())?;
    let cw = c.width as usize;
    let (fw, fh) = (i64::from(f.width), i64::from(f.height));
    let at = |x: i64, y: i64| -> ColorTexel {
        let x = x.clamp(0, fw - 1) as usize;
        let y = y.clamp(0, fh - 1) as usize;
        finer[y * fw as usize + x]
    };
    for (dst, y) in band.chunks_exact_mut(cw).zip(rows.rows()) {
        let (fy, ny, wy) = convolution_weights(y, c.height, f.height, sigma);
        for (x, o) in dst.iter_mut().enumerate() {
            let (fx, nx, wx) = convolution_weights(x as u32, c.width, f.width, sigma);
            let c0 = at(2 * x as i64, 2 * i64::from(y));
            let mut acc = [0.0f32; 3];
            for (v, wv) in wy.iter().enumerate().take(ny) {
                let mut row = [0.0f32; 3];
                for (u, wu) in wx.iter().enumerate().take(nx) {
                    let t = at(fx + u as i64, fy + v as i64);
                    for k in 0..3 {
                        row[k] += wu * (t[k] - c0[k]);
                    }
                }
                for k in 0..3 {
                    acc[k] += wv * row[k];
                }
            }
            *o = [c0[0] + acc[0], c0[1] + acc[1], c0[2] + acc[2]];
        }
    }
    Ok(())
}

/// Builds the whole color pyramid of `color` into `dst` (level 0 a copy,
/// then [`try_build_color_level_rows`] level by level).
///
/// # Errors
/// [`Error::InsufficientSize`] if `dst` is shorter than
/// [`try_color_pyramid_len`]; [`Error::InvalidArgument`] for a non-finite
/// texel or sigma. Nothing is written on error.
///
/// # Panics
/// Never.
pub fn try_build_color_pyramid(
    dst: &mut [ColorTexel],
    color: &ImageView<'_, ColorTexel>,
    sigma: f32,
) -> Result<(), Error> {
    validate_sigma(sigma)?;
    let layout = HiZLayout::try_new(color.width(), color.height())?;
    if dst.len() < try_color_pyramid_len(color.width(), color.height())? {
        return Err(Error::InsufficientSize);
    }
    let l0 = layout.level(0).ok_or(Error::InvalidArgument)?;
    // Validate every texel before writing anything.
    for y in 0..color.height() {
        if let Some(row) = color.row(y) {
            if !row.iter().all(|&c| finite3(c)) {
                return Err(Error::InvalidArgument);
            }
        }
    }
    try_build_color_level0_rows(&mut dst[l0.range()], color, RowRange::try_all(l0.height)?)?;
    for level in 1..layout.level_count() {
        let (f, c) = match (layout.level(level - 1), layout.level(level)) {
            (Some(f), Some(c)) => (f, c),
            _ => return Err(Error::InvalidArgument),
        };
        let (head, tail) = dst.split_at_mut(c.offset);
        try_build_color_level_rows(
            &mut tail[..c.len()],
            &head[f.range()],
            &layout,
            level,
            RowRange::try_all(c.height)?,
            sigma,
        )?;
    }
    try_stamp_color_pyramid(dst, color.width(), color.height())
}

/// Whether a Hi-Z closest depth is a foreground surface (not NaN, below the
/// far plane).
#[inline]
pub(super) fn foreground(z: f32, far: f32) -> bool {
    z > 0.0 && z < far
}

/// Builds rows `rows` of visibility level 0 from the Hi-Z: 1 where the
/// pixel has a foreground surface (closest depth below the far plane), 0
/// where it has none (module docs, "Visibility").
///
/// # Errors
/// [`Error::InvalidArgument`] if rows exceed the height;
/// [`Error::InsufficientSize`] if `band` is shorter than `rows.len() *
/// width`. Nothing is written on error.
///
/// # Panics
/// Never.
pub fn try_build_visibility_level0_rows(
    band: &mut [f32],
    hiz: &HiZ<'_>,
    rows: RowRange,
) -> Result<(), Error> {
    let l = hiz.layout().level(0).ok_or(Error::InvalidArgument)?;
    if rows.end() > l.height {
        return Err(Error::InvalidArgument);
    }
    let w = l.width as usize;
    if band.len() < rows.len() as usize * w {
        return Err(Error::InsufficientSize);
    }
    let far = hiz.camera().far();
    for (dst, y) in band.chunks_exact_mut(w).zip(rows.rows()) {
        for (x, o) in dst.iter_mut().enumerate() {
            let t = hiz.texel(0, x as u32, y).unwrap_or([f32::NAN; 2]);
            *o = if foreground(t[0], far) { 1.0 } else { 0.0 };
        }
    }
    Ok(())
}

/// Builds rows `rows` of visibility level `level >= 1` from the complete
/// visibility level `level - 1` (`finer`) and the Hi-Z's level `level - 1`
/// (seed 004 Sec. 4.4.2 / Listing 4.4 as read in the module docs: the mean
/// over the children of `V_child * (1 - e_child)`).
///
/// # Errors
/// [`Error::InvalidArgument`] for `level` 0 or past the last level, or rows
/// past the level's height; [`Error::InsufficientSize`] if `finer` or
/// `band` is too short. Nothing is written on error.
///
/// # Panics
/// Never.
pub fn try_build_visibility_level_rows(
    band: &mut [f32],
    finer: &[f32],
    hiz: &HiZ<'_>,
    level: u32,
    rows: RowRange,
) -> Result<(), Error> {
    let layout = hiz.layout();
    let (f, c) = layout.try_band_levels(level, rows, finer.len(), band.len())?;
    let cw = c.width as usize;
    let far = hiz.camera().far();
    let fw = f.width as usize;
    for (dst, y) in band.chunks_exact_mut(cw).zip(rows.rows()) {
        let ys = children(y, c.height, f.height);
        for (x, o) in dst.iter_mut().enumerate() {
            let xs = children(x as u32, c.width, f.width);
            // The cell's slab over its foreground children.
            let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
            for yy in ys.clone() {
                for xx in xs.clone() {
                    let t = hiz.texel(level - 1, xx, yy).unwrap_or([f32::NAN; 2]);
                    if foreground(t[0], far) {
                        lo = lo.min(t[0]);
                        hi = hi.max(t[1]);
                    }
                }
            }
            let range = hi - lo;
            let flat = !(range > 1e-6 * hi);
            let (mut sum, mut n) = (0.0f32, 0u32);
            for yy in ys.clone() {
                for xx in xs.clone() {
                    n += 1;
                    let v = finer[yy as usize * fw + xx as usize];
                    let t = hiz.texel(level - 1, xx, yy).unwrap_or([f32::NAN; 2]);
                    if !foreground(t[0], far) {
                        continue;
                    }
                    let keep = if flat {
                        1.0
                    } else {
                        1.0 - ((t[0] - lo) / range).clamp(0.0, 1.0)
                    };
                    sum += v * keep;
                }
            }
            *o = if n > 0 { sum / n as f32 } else { 0.0 };
        }
    }
    Ok(())
}

#[inline]
fn children(c: u32, coarse: u32, fine: u32) -> core::ops::Range<u32> {
    let hi = if c + 1 >= coarse { fine } else { 2 * c + 2 };
    2 * c..hi
}

/// Builds the whole visibility pyramid of `hiz` into `dst`.
///
/// # Errors
/// [`Error::InsufficientSize`] if `dst` is shorter than
/// [`try_visibility_pyramid_len`]. Nothing is written on error.
///
/// # Panics
/// Never.
pub fn try_build_visibility_pyramid(dst: &mut [f32], hiz: &HiZ<'_>) -> Result<(), Error> {
    let layout = *hiz.layout();
    if dst.len() < try_visibility_pyramid_len(layout.width(), layout.height())? {
        return Err(Error::InsufficientSize);
    }
    let l0 = layout.level(0).ok_or(Error::InvalidArgument)?;
    try_build_visibility_level0_rows(&mut dst[l0.range()], hiz, RowRange::try_all(l0.height)?)?;
    for level in 1..layout.level_count() {
        let (f, c) = match (layout.level(level - 1), layout.level(level)) {
            (Some(f), Some(c)) => (f, c),
            _ => return Err(Error::InvalidArgument),
        };
        let (head, tail) = dst.split_at_mut(c.offset);
        try_build_visibility_level_rows(
            &mut tail[..c.len()],
            &head[f.range()],
            hiz,
            level,
            RowRange::try_all(c.height)?,
        )?;
    }
    try_stamp_visibility_pyramid(dst, hiz)
}
