//! Hi-Z: a min/max depth pyramid in one caller buffer and the hierarchical
//! screen-space ray traversal over it (seed 004, Sec. 4.4.1 Hi-Z pass,
//! Sec. 4.4.3 ray-tracing pass with Listings 4.2 and 4.5, Sec. 4.6.6 travel
//! behind surfaces, Sec. 4.6.7 ray marching toward the camera, Sec. 4.7.1
//! combining linear and Hi-Z traversal).
//!
//! # Example
//! ```rust
//! use core::f32::consts::FRAC_PI_2;
//! use refl_core::glam::Vec3;
//! use refl_core::{try_build_hiz, try_hiz_len, try_trace_hiz, Camera, DepthConvention, DepthImage};
//! use refl_core::{Error, HiZ, HiZOptions, ImageView, Ray, Thickness, Trace, HIZ_STAMP_TEXELS};
//!
//! // 16 x 16 pixels: the left half sees a surface at depth 5, the right half one at 10.
//! let cam = Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, FRAC_PI_2, 0.1, 100.0, 16, 16)?;
//! let depth: Vec<f32> = (0..256).map(|i| if i % 16 < 8 { 5.0 } else { 10.0 }).collect();
//! let image = DepthImage::try_new(ImageView::try_new(&depth, 16, 16, 16)?, cam, DepthConvention::Linear)?;
//! // Levels of 16 x 16, 8 x 8, 4 x 4, 2 x 2 and 1 x 1 texels, then the stamp.
//! assert_eq!(try_hiz_len(16, 16)?, 256 + 64 + 16 + 4 + 1 + HIZ_STAMP_TEXELS);
//! let mut pyramid = vec![[0.0f32; 2]; try_hiz_len(16, 16)?];
//! try_build_hiz(&mut pyramid, &image)?;
//! let hiz = HiZ::try_new(&pyramid, cam, DepthConvention::Linear)?;
//! assert_eq!(hiz.texel(4, 0, 0), Some([5.0, 10.0])); // [closest, farthest]
//! assert_eq!(hiz.texel(1, 3, 0), Some([5.0, 5.0]));
//!
//! // From (0, 0, -2) toward (8, 3, -10) on the far half: pixel (14.4, 5.6), t = sqrt(137).
//! let ray = Ray { origin: Vec3::new(0.0, 0.0, -2.0), dir: Vec3::new(8.0, 3.0, -8.0).normalize() };
//! let trace = try_trace_hiz(&hiz, Thickness::Constant(0.5), ray, f32::INFINITY, &HiZOptions::default())?;
//! let Trace::Hit(hit) = trace else { panic!("the ray reaches the far half") };
//! assert_eq!(hit.pixel.floor().to_array(), [14.0, 5.0]);
//! assert!((hit.t - 137f32.sqrt()).abs() < 1e-3);
//!
//! // The pyramid records its camera: another camera is refused.
//! let other = Camera::try_look_at(Vec3::X, Vec3::X - Vec3::Z, Vec3::Y, FRAC_PI_2, 0.1, 100.0, 16, 16)?;
//! assert_eq!(HiZ::try_new(&pyramid, other, DepthConvention::Linear).unwrap_err(), Error::InvalidArgument);
//! # Ok::<(), Error>(())
//! ```
//!
//! # Pyramid
//!
//! Every texel is `[closest, farthest]`: the smallest and largest **linear
//! depth** (positive distance along the view's -Z) of the surfaces under it.
//! Level 0 is the full-resolution image, decoded once from the depth
//! image's [`DepthConvention`]; level `L` has size
//! `max(1, w >> L) x max(1, h >> L)` and the pyramid ends at `1 x 1`
//! ([`HiZLayout`]).
//!
//! * Why linear depth and not the stored convention: the traversal compares
//!   in `1 / z` and adds thickness in linear units, so decoding once per
//!   texel at build time replaces two decodes per fetch, and "closest" and
//!   "farthest" are `min` and `max` in every convention. The seed's listing
//!   takes the minimum of post-projection depth (Sec. 4.5.1, Listing 4.3);
//!   design.md erratum: with reversed-Z the closest surface is the
//!   *maximum* stored value. Decoding first applies that flip exactly.
//! * Non-power-of-two sizes (the seed's listing assumes powers of two,
//!   design.md erratum): coarse texel `(i, j)` of level `L` folds texels
//!   `2i..2i+2` x `2j..2j+2` of level `L - 1`, and the last column (row)
//!   also folds the odd leftover column (row), a 3x2, 2x3 or 3x3
//!   footprint, so every coarse texel bounds all texels under it. In level-0
//!   pixels, cell `i` of level `L` covers `[i 2^L, (i + 1) 2^L)`, except the
//!   last cell, which reaches the image edge.
//! * No surface: a stored depth that decodes to NaN or to a linear depth
//!   `<= 0` is "no surface" and is stored as NaN. `min`/`max` ignore NaN
//!   (IEEE `minNum`/`maxNum`), so a coarse texel is NaN only if no texel
//!   under it has a surface. A depth on the far plane (`z >= far`, e.g. a
//!   cleared buffer, or `+inf` with an infinite far plane) is kept in the
//!   pyramid but is background for the traversal: it is never hit.
//!
//! # Traversal
//!
//! [`try_trace_hiz`] clips the ray to the view frustum and `[0, t_max]`, then
//! walks the projected segment in screen space: pixel `(x, y)` and
//! `q = 1 / z`, which is affine along the projected segment (Sec. 4.4.3:
//! the perspective divide makes post-projection depth, an affine function of
//! `1 / z`, linear in screen space). A ray point hits level-0 texel `(x, y)`
//! when its linear depth `z` satisfies `z_front <= z <= z_front + thickness`
//! (or `<= z_back` with a back-face image), the shared rule of
//! [`crate::trace`]. A cell of level `L` can contain such a point only
//! where `q` lies in `[1 / (farthest + thickness), 1 / closest]`; the walk
//! (Listing 4.2):
//!
//! 1. Prologue (Sec. 4.7.1): [`HiZOptions::prologue_steps`] unit steps,
//!    pixel by pixel, before the hierarchy, to get away from the surface the
//!    ray starts on.
//! 2. Hierarchical walk from [`HiZOptions::start_level`]: in the current
//!    cell, intersect the part of the segment inside the cell with the
//!    cell's depth slab. If it is empty, cross to the next cell and go up a
//!    level (Listing 4.5: `level + 2` then `--level`), except while the
//!    walk is still inside the coarser cell it last descended from and
//!    before the end of that cell's possible-hit interval (going up would
//!    only fetch that cell again). Otherwise advance to
//!    the slab entry (the "minimum depth plane" of Listing 4.2 for rays
//!    moving away from the camera, the farthest plane of the max pyramid
//!    for rays moving toward it, Sec. 4.6.7) and go down a level. At level 0
//!    the slab entry is the hit.
//! 3. Travel behind surfaces (Sec. 4.6.6): a cell whose whole slab lies in
//!    front of the ray's depth range (the ray is behind `farthest +
//!    thickness` everywhere in it) is crossed like empty space.
//! 4. At [`HiZOptions::stop_level`] `> 0` a cell that may hold a hit is
//!    resolved by unit steps through its pixels (Sec. 4.7.1, "end the Hi-Z
//!    traversal at a much earlier level ... then continue with another
//!    linear search"), then the walk goes on. Every setting returns the
//!    same, exact first hit; the levels only trade iterations for fetches.
//!
//! Cell-edge stall: Listing 4.5 finds the current cell from the ray
//! position (`getCell`) and nudges crossings by `HIZ_CROSS_EPSILON`. A
//! position exactly on a cell boundary (axis-aligned rays, rays through
//! cell corners, rays moving toward smaller coordinates, which land on the
//! lower boundary that `floor` assigns to the old cell) then finds the old
//! cell again and makes no progress. Here the walk keeps an integer
//! *frontier*: the level-0 pixel the ray is in, which only moves forward
//! along each axis of motion; a crossing sets it to the first pixel past
//! the boundary, and positions are rounded toward the direction of motion.
//! Every iteration either descends a level or moves the frontier by at least
//! one pixel, so the walk always terminates, even without the iteration
//! cap. [`HiZStats::boundary_ties`] counts the positions where plain `floor`
//! would have picked another cell.
//!
//! The result is the shared [`Trace`] with [`Work`]: `steps` counts cell
//! crossings (at any level, prologue and unit steps included), `fetches`
//! every pyramid texel read (and back-face texel read), `iterations` the
//! hierarchical loop iterations (the capped quantity).
//!
//! The loop is specialized rather than branched: one monomorphized walk per
//! direction class (signs of `dx`, `dy` and `dq`), thickness model and
//! statistics setting, with the segment, the level table and the thickness
//! read once per ray; per cell it does integer cell arithmetic, one texel
//! fetch, the exit parameter toward the two cell sides ahead and the slab
//! interval. The classes do the same f32 operations as one general walk
//! would, in the same order (divisions stay divisions), so every class
//! returns the same bits; `max`/`min` without NaN fix-ups are used only
//! where an operand is never NaN (see `max_nn`).
//!
//! What the loop leaves out, each without changing a result bit (issue 14
//! part 1, measured with `examples/depth_kernels_bench --check`):
//!
//! * Work it can derive: every hierarchical iteration fetches exactly one
//!   texel, so [`Work::fetches`] is the iteration count plus the prologue,
//!   unit-step, back-face and end reads, not a counter kept per visit.
//! * Table arithmetic: the level table is kept as (first texel, last cell
//!   index per axis, row stride), computed once when the [`HiZ`] is bound;
//!   a level-0 visit (prologue, unit steps) takes the frontier pixel as its
//!   cell with no table read at all.
//! * Syncs that cannot move the frontier: a descent whose slab entry is not
//!   past the current `s` keeps the frontier where the last crossing or
//!   descent put it at that same `s` (the statistics walk still syncs, to
//!   count boundary ties; see `Walker::sync_in`), and a sync whose position
//!   has not passed the frontier pixel's far side returns the pixel without
//!   rounding the position (`Axis::sync_stays`).
//! * Tests it does not need: a crossing branches once on the nearer exit
//!   (one side, or both at a corner) rather than testing each side against
//!   their minimum; a coarse texel's far depth is one `max` (equal depths
//!   are equal bits); a texel index outside the pyramid, impossible for a
//!   bound [`HiZ`], ends the walk rather than producing a fallback texel.
//! * Calls: every step is inlined and the hit and end-of-segment builders
//!   have one call site each, so the per-ray constants stay in registers
//!   instead of being stored for out-of-line code.
//!
//! Hoisting the reciprocals of `dx`, `dy` and `dq` (a multiplication per
//! exit and slab side instead of a division) was measured and left out: the
//! same instruction count (a `mulss` for a `divss`) and, on the bench's
//! 6 million checked traces, 8 other hit texels and 20 hit/miss flips at
//! ties; its gain would be latency only.
//!
//! The batch entry point [`try_trace_hiz_rays`] walks eight rays at once
//! on x86-64 CPUs with AVX2 (detected at run time): the same walk in eight
//! lanes, each refilled with the batch's next ray as soon as its ray
//! finishes, returning the scalar walk's results bit for bit (module
//! `avx2`; [`hiz_stream_lanes`] says which loop runs,
//! [`try_trace_hiz_rays_scalar`] forces the scalar one).
//!
//! There is no self-intersection skip: a ray whose origin already lies in a
//! texel's hit slab hits at `t = 0`. Start reflection rays slightly off the
//! surface (the seed crosses one cell first for the same reason).

#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
#[allow(unsafe_code)]
mod avx2;

use crate::trace::{
    try_validate_ray, DepthHit, DepthImage, Miss, Thickness, Trace, Work, RESOLVED_DEPTH,
};
use crate::{Camera, DepthConvention, Error, Ray, RowRange};
use core::ops::Range;
use glam::{Mat4, Vec2, Vec4};

/// One pyramid texel: `[closest, farthest]` linear depth (NaN: no surface).
pub type HiZTexel = [f32; 2];

/// Most levels a pyramid can have (a `u32::MAX`-wide image halves 31 times).
pub const MAX_LEVELS: usize = 32;

/// Where one pyramid level lives in the caller buffer: texels
/// `offset .. offset + width * height`, row by row, row stride `width`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct HiZLevel {
    /// Index of the level's first texel in the pyramid buffer.
    pub offset: usize,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
}

impl HiZLevel {
    /// Number of texels, `width * height`.
    pub const fn len(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Always `false`: a level holds at least one texel.
    pub const fn is_empty(&self) -> bool {
        false
    }

    /// The level's texels as an index range of the pyramid buffer.
    pub const fn range(&self) -> Range<usize> {
        self.offset..self.offset + self.len()
    }
}

/// Where one row-band build of a pyramid level writes and reads
/// ([`HiZLayout::try_band`]): index ranges of the pyramid buffer.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct PyramidBand {
    /// The texels of the band's rows of the level being built.
    pub band: Range<usize>,
    /// The whole finer level the band is built from; `None` for level 0
    /// (built from the image).
    pub finer: Option<Range<usize>>,
}

/// The layout of a Hi-Z pyramid for a `width x height` image: level count
/// and where each level lives in the one caller buffer (levels back to back,
/// finest first).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct HiZLayout {
    width: u32,
    height: u32,
    count: u32,
    len: usize,
    levels: [HiZLevel; MAX_LEVELS],
}

impl HiZLayout {
    /// The layout for a `width x height` image. Level `L` is
    /// `max(1, width >> L) x max(1, height >> L)`; the last level is `1 x 1`.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for a zero size or a texel count that does
    /// not fit in `usize`.
    pub fn try_new(width: u32, height: u32) -> Result<Self, Error> {
        if width == 0 || height == 0 {
            return Err(Error::InvalidArgument);
        }
        let mut levels = [HiZLevel::default(); MAX_LEVELS];
        let (mut w, mut h) = (width, height);
        let mut offset: u64 = 0;
        let mut count = 0usize;
        loop {
            let offset_usize = usize::try_from(offset).map_err(|_| Error::InvalidArgument)?;
            levels[count] = HiZLevel {
                offset: offset_usize,
                width: w,
                height: h,
            };
            // w * h < 2^64; the sum is checked.
            offset = offset
                .checked_add(u64::from(w) * u64::from(h))
                .ok_or(Error::InvalidArgument)?;
            count += 1;
            if (w == 1 && h == 1) || count == MAX_LEVELS {
                break;
            }
            w = (w / 2).max(1);
            h = (h / 2).max(1);
        }
        let len = usize::try_from(offset).map_err(|_| Error::InvalidArgument)?;
        Ok(Self {
            width,
            height,
            count: count as u32,
            len,
            levels,
        })
    }

    /// Width of level 0.
    pub const fn width(&self) -> u32 {
        self.width
    }

    /// Height of level 0.
    pub const fn height(&self) -> u32 {
        self.height
    }

    /// Number of levels (level 0 included; at least 1).
    pub const fn level_count(&self) -> u32 {
        self.count
    }

    /// Total texels of all levels: the length of the caller buffer.
    pub const fn len(&self) -> usize {
        self.len
    }

    /// Always `false`: a pyramid holds at least one texel.
    pub const fn is_empty(&self) -> bool {
        false
    }

    /// Level `level`, or `None` past the last level.
    pub fn level(&self, level: u32) -> Option<HiZLevel> {
        (level < self.count).then(|| self.levels[level as usize])
    }

    /// The finer and the coarser level of a row-band build of level
    /// `level` from level `level - 1` (the `*_level_rows` builds of Hi-Z,
    /// color and visibility pyramids), after checking the band: `rows`
    /// inside the coarser level, `finer_len` elements for the whole finer
    /// level and `band_len` for the band's rows.
    ///
    /// # Errors
    /// * [`Error::InvalidArgument`]: `level` is 0 or past the last level,
    ///   or `rows` ends below the coarser level.
    /// * [`Error::InsufficientSize`]: `finer_len` or `band_len` too small.
    pub(crate) fn try_band_levels(
        &self,
        level: u32,
        rows: RowRange,
        finer_len: usize,
        band_len: usize,
    ) -> Result<(HiZLevel, HiZLevel), Error> {
        if level == 0 {
            return Err(Error::InvalidArgument);
        }
        let (f, c) = match (self.level(level - 1), self.level(level)) {
            (Some(f), Some(c)) => (f, c),
            _ => return Err(Error::InvalidArgument),
        };
        if rows.end() > c.height {
            return Err(Error::InvalidArgument);
        }
        if finer_len < f.len() || band_len < rows.len() as usize * c.width as usize {
            return Err(Error::InsufficientSize);
        }
        Ok((f, c))
    }

    /// The texels of rows `rows` of level `level` as an index range of the
    /// pyramid buffer, for handing row bands to threads; `None` if the level
    /// does not exist or the rows exceed its height.
    pub fn rows_range(&self, level: u32, rows: RowRange) -> Option<Range<usize>> {
        let l = self.level(level)?;
        (rows.end() <= l.height).then(|| {
            let w = l.width as usize;
            l.offset + rows.start() as usize * w..l.offset + rows.end() as usize * w
        })
    }

    /// Where a row-band build of rows `rows` of level `level` (the
    /// `*_level0_rows` / `*_level_rows` builds of Hi-Z, color and visibility
    /// pyramids) writes and reads in a pyramid buffer of `buffer_len`
    /// texels laid out as `self`: the band's texels and, for `level > 0`,
    /// the whole finer level `level - 1` it is built from (which lies
    /// before the band, so the two never overlap). A threaded host (or the
    /// C ABI, which gets one band per call) turns the ranges into the
    /// slices of each call; [`HiZLayout::try_split_band`] does it for one
    /// `&mut` buffer.
    ///
    /// # Errors
    /// * [`Error::InvalidArgument`]: `level` past the last level, or `rows`
    ///   ending below the level's height.
    /// * [`Error::InsufficientSize`]: `buffer_len` below [`HiZLayout::len`].
    pub fn try_band(
        &self,
        level: u32,
        rows: RowRange,
        buffer_len: usize,
    ) -> Result<PyramidBand, Error> {
        let band = self.rows_range(level, rows).ok_or(Error::InvalidArgument)?;
        if buffer_len < self.len {
            return Err(Error::InsufficientSize);
        }
        let finer = match level {
            0 => None,
            _ => Some(self.levels[level as usize - 1].range()),
        };
        Ok(PyramidBand { band, finer })
    }

    /// The band [`HiZLayout::try_band`] describes, as slices of `dst`: the
    /// rows to write and the finer level to read (`None` for level 0).
    ///
    /// # Errors
    /// As [`HiZLayout::try_band`] with `dst.len()`.
    ///
    /// # Examples
    /// ```
    /// use refl_core::{HiZLayout, RowRange};
    /// let layout = HiZLayout::try_new(8, 4).unwrap();
    /// let mut pyramid = vec![[0.0f32; 2]; layout.len()];
    /// let rows = RowRange::try_new(0, 1, 2).unwrap();
    /// let (band, finer) = layout.try_split_band(&mut pyramid, 1, rows).unwrap();
    /// assert_eq!((band.len(), finer.map(<[_]>::len)), (4, Some(32)));
    /// ```
    pub fn try_split_band<'a, T>(
        &self,
        dst: &'a mut [T],
        level: u32,
        rows: RowRange,
    ) -> Result<(&'a mut [T], Option<&'a [T]>), Error> {
        let b = self.try_band(level, rows, dst.len())?;
        let (head, tail) = dst.split_at_mut(b.band.start);
        let band = &mut tail[..b.band.end - b.band.start];
        Ok((band, b.finer.map(|f| &head[f])))
    }

    /// The level-0 pixels under texel `(x, y)` of level `level`:
    /// `[x 2^L, (x + 1) 2^L) x [y 2^L, (y + 1) 2^L)`, the last column and row
    /// reaching the image edge. `None` outside the level.
    pub fn footprint(&self, level: u32, x: u32, y: u32) -> Option<(Range<u32>, Range<u32>)> {
        let l = self.level(level)?;
        (x < l.width && y < l.height).then(|| {
            (
                cell_span(x, level, l.width, self.width),
                cell_span(y, level, l.height, self.height),
            )
        })
    }
}

/// Level-0 span of cell `c` of a level `level` with `cells` cells along an
/// axis of `full` pixels.
#[inline]
fn cell_span(c: u32, level: u32, cells: u32, full: u32) -> Range<u32> {
    let lo = (u64::from(c) << level) as u32;
    let hi = if c + 1 >= cells {
        full
    } else {
        (u64::from(c + 1) << level) as u32
    };
    lo..hi
}

/// Number of texels ([`HiZTexel`]s) of the Hi-Z pyramid of a
/// `width x height` image, all levels: the size of the caller buffer.
///
/// # Errors
/// As [`HiZLayout::try_new`].
pub fn try_hiz_len(width: u32, height: u32) -> Result<usize, Error> {
    try_pyramid_len::<HiZTexel>(width, height)
}

/// Texels after the last level of a Hi-Z pyramid that hold its
/// [`PyramidStamp`]; counted in [`try_hiz_len`].
pub const HIZ_STAMP_TEXELS: usize = <HiZTexel as PyramidTexel>::STAMP_TEXELS;

mod sealed {
    pub trait Sealed {}
    impl Sealed for [f32; 2] {}
    impl Sealed for [f32; 3] {}
    impl Sealed for f32 {}
}

/// The texel types of refl's screen pyramids, all laid out as
/// [`HiZLayout`] and ended by a [`PyramidStamp`]: [`HiZTexel`] (Hi-Z),
/// `[f32; 3]` (the cone's color pyramid) and `f32` (its visibility
/// pyramid). Sealed.
pub trait PyramidTexel: Copy + sealed::Sealed {
    /// Texels after the last level that hold the stamp (four 32-bit words).
    const STAMP_TEXELS: usize;
    /// First word of the stamp: which pyramid it is.
    #[doc(hidden)]
    const MAGIC: u32;
    /// The texels as 32-bit words.
    #[doc(hidden)]
    fn words(texels: &[Self]) -> &[f32];
    /// The texels as 32-bit words, writable.
    #[doc(hidden)]
    fn words_mut(texels: &mut [Self]) -> &mut [f32];
}

impl PyramidTexel for [f32; 2] {
    const STAMP_TEXELS: usize = 2;
    const MAGIC: u32 = 0x5a48_4652; // "RFHZ"
    fn words(texels: &[Self]) -> &[f32] {
        texels.as_flattened()
    }
    fn words_mut(texels: &mut [Self]) -> &mut [f32] {
        texels.as_flattened_mut()
    }
}

impl PyramidTexel for [f32; 3] {
    const STAMP_TEXELS: usize = 2;
    const MAGIC: u32 = 0x5043_4652; // "RFCP"
    fn words(texels: &[Self]) -> &[f32] {
        texels.as_flattened()
    }
    fn words_mut(texels: &mut [Self]) -> &mut [f32] {
        texels.as_flattened_mut()
    }
}

impl PyramidTexel for f32 {
    const STAMP_TEXELS: usize = 4;
    const MAGIC: u32 = 0x5056_4652; // "RFVP"
    fn words(texels: &[Self]) -> &[f32] {
        texels
    }
    fn words_mut(texels: &mut [Self]) -> &mut [f32] {
        texels
    }
}

/// Elements of a pyramid of texel type `T` for a `width x height` image:
/// its levels ([`HiZLayout::len`]) and then `T::STAMP_TEXELS`. What
/// [`try_hiz_len`], `cone::try_color_pyramid_len` and
/// `cone::try_visibility_pyramid_len` return.
///
/// # Errors
/// As [`HiZLayout::try_new`].
pub fn try_pyramid_len<T: PyramidTexel>(width: u32, height: u32) -> Result<usize, Error> {
    HiZLayout::try_new(width, height)?
        .len()
        .checked_add(T::STAMP_TEXELS)
        .ok_or(Error::InvalidArgument)
}

/// What a built screen pyramid records about what it was built from, in
/// the [`PyramidTexel::STAMP_TEXELS`] texels after its last level: the
/// image size and, for pyramids built from a depth image (Hi-Z, and the
/// visibility pyramid built from a Hi-Z), the camera's
/// [`Camera::fingerprint`] (0 for the color pyramid, built from a color
/// image alone). Binding a pyramid to a camera whose stamp differs ([`HiZ::try_new`],
/// `cone::ConePyramids::try_new`) is an error, so a pyramid of another
/// size, of an earlier frame's camera, or never built, is refused rather
/// than traced into silent misses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PyramidStamp {
    /// Width of the image (level 0).
    pub width: u32,
    /// Height of the image (level 0).
    pub height: u32,
    /// [`Camera::fingerprint`] of the image's camera, or 0 (size only).
    pub camera: u32,
}

impl PyramidStamp {
    /// The stamp of a pyramid built from a depth image of `camera`.
    pub fn of(camera: &Camera) -> Self {
        Self {
            width: camera.width(),
            height: camera.height(),
            camera: camera.fingerprint(),
        }
    }

    /// The stamp of a pyramid built from a `width x height` image without a
    /// camera (the color pyramid).
    pub const fn of_size(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            camera: 0,
        }
    }

    fn from_words<T: PyramidTexel>(w: &[f32]) -> Option<Self> {
        match w {
            [m, width, height, camera, ..] if m.to_bits() == T::MAGIC => Some(Self {
                width: width.to_bits(),
                height: height.to_bits(),
                camera: camera.to_bits(),
            }),
            _ => None,
        }
    }

    /// The stamp where a `width x height` pyramid's levels end in
    /// `pyramid`, or `None` if none is there (not built, or built for
    /// another size).
    pub fn read<T: PyramidTexel>(pyramid: &[T], width: u32, height: u32) -> Option<Self> {
        let at = HiZLayout::try_new(width, height).ok()?.len();
        Self::from_words::<T>(T::words(pyramid.get(at..)?))
    }

    /// The stamp in the last `T::STAMP_TEXELS` texels of `pyramid` (where a
    /// buffer of exactly the pyramid's length holds it), for diagnosing a
    /// mismatch: what the pyramid was built for.
    pub fn read_tail<T: PyramidTexel>(pyramid: &[T]) -> Option<Self> {
        let n = pyramid.len().checked_sub(T::STAMP_TEXELS)?;
        Self::from_words::<T>(T::words(&pyramid[n..]))
    }

    /// Writes the stamp after the last level of the `width x height`
    /// pyramid in `pyramid`: the last step of a row-band build.
    ///
    /// # Errors
    /// [`Error::InsufficientSize`] if `pyramid` is shorter than
    /// [`try_pyramid_len`]; [`Error::InvalidArgument`] for a zero size.
    /// Nothing is written on error.
    pub fn try_write<T: PyramidTexel>(&self, pyramid: &mut [T]) -> Result<(), Error> {
        let at = HiZLayout::try_new(self.width, self.height)?.len();
        let slot = pyramid
            .get_mut(at..at + T::STAMP_TEXELS)
            .ok_or(Error::InsufficientSize)?;
        let w = T::words_mut(slot);
        w.fill(0.0);
        w[..4].copy_from_slice(&[
            f32::from_bits(T::MAGIC),
            f32::from_bits(self.width),
            f32::from_bits(self.height),
            f32::from_bits(self.camera),
        ]);
        Ok(())
    }
}

/// Writes the [`PyramidStamp`] of `camera` after the last level of the
/// Hi-Z pyramid in `dst` (laid out for `camera`'s size): the last step of
/// a row-band build ([`try_build_hiz_level0_rows`],
/// [`try_build_hiz_level_rows`]); [`try_build_hiz`] does it itself.
///
/// # Errors
/// [`Error::InsufficientSize`] if `dst` holds fewer than
/// [`try_hiz_len`]`(camera.width(), camera.height())` texels. Nothing is
/// written on error.
///
/// # Panics
/// Never.
pub fn try_stamp_hiz(dst: &mut [HiZTexel], camera: &Camera) -> Result<(), Error> {
    PyramidStamp::of(camera).try_write(dst)
}

/// Decoded linear depth as stored in the pyramid: NaN for "no surface"
/// (NaN or `z <= 0`).
#[inline]
fn sanitize(z: f32) -> f32 {
    if z > 0.0 {
        z
    } else {
        f32::NAN
    }
}

/// Builds rows `rows` of level 0 (seed 004 Sec. 4.4.1: "Mip 0 is our depth
/// buffer"): each texel is `[z, z]` with `z` the linear depth decoded from
/// `depth`'s convention, or NaN for no surface. `band` holds exactly those
/// rows, row stride = image width: texel `(x, y)` goes to
/// `band[(y - rows.start()) * width + x]` (take it from the pyramid buffer
/// with [`HiZLayout::rows_range`]).
///
/// # Errors
/// [`Error::InvalidArgument`] if `rows` exceed the image height;
/// [`Error::InsufficientSize`] if `band` is shorter than
/// `rows.len() * width`. Nothing is written on error.
///
/// # Panics
/// Never.
pub fn try_build_hiz_level0_rows(
    band: &mut [HiZTexel],
    depth: &DepthImage<'_>,
    rows: RowRange,
) -> Result<(), Error> {
    if rows.end() > depth.height() {
        return Err(Error::InvalidArgument);
    }
    let w = depth.width() as usize;
    let need = (rows.len() as usize)
        .checked_mul(w)
        .ok_or(Error::InvalidArgument)?;
    if band.len() < need {
        return Err(Error::InsufficientSize);
    }
    let (cam, c) = (depth.camera(), depth.convention());
    // `Camera::decode_depth` with its convention and far-plane branches
    // taken once per call, not per texel, so that each row's loop is
    // branch-free (and vectorizes): the same expressions, evaluated in the
    // same order (`n * f` and `f - n` are the same products hoisted), so
    // the same bits. Tested against `decode_depth` texel by texel.
    let (n, f) = (cam.near(), cam.far());
    let (nf, fmn) = (n * f, f - n);
    let mut rows_of = |decode: &dyn Fn(&mut [HiZTexel], &[f32])| {
        for (dst, y) in band.chunks_exact_mut(w).zip(rows.rows()) {
            if let Some(src) = depth.depth().row(y) {
                decode(dst, src);
            }
        }
    };
    match c {
        DepthConvention::Linear => rows_of(&|dst, src| level0_row(dst, src, |d| d)),
        DepthConvention::ZeroToOne if f.is_infinite() => {
            rows_of(&|dst, src| level0_row(dst, src, |d| n / (1.0 - d)))
        }
        DepthConvention::ZeroToOne => rows_of(&|dst, src| {
            level0_row(dst, src, |d| if d == 1.0 { f } else { nf / (f - d * fmn) })
        }),
        DepthConvention::ReversedZ if f.is_infinite() => {
            rows_of(&|dst, src| level0_row(dst, src, |d| n / d))
        }
        DepthConvention::ReversedZ => rows_of(&|dst, src| {
            level0_row(dst, src, |d| if d == 0.0 { f } else { nf / (n + d * fmn) })
        }),
    }
    Ok(())
}

/// One row of level 0: `[z, z]` with `z = sanitize(decode(d))`.
#[inline(always)]
fn level0_row(dst: &mut [HiZTexel], src: &[f32], decode: impl Fn(f32) -> f32) {
    for (o, &d) in dst.iter_mut().zip(src) {
        let z = sanitize(decode(d));
        *o = [z, z];
    }
}

/// Builds rows `rows` of level `level >= 1` from the complete level
/// `level - 1` (seed 004 Sec. 4.4.1 / Listing 4.3, min and max of the 2x2
/// texels below, plus the odd leftover column/row at the last column/row:
/// a conservative 3x2, 2x3 or 3x3 footprint). NaN (no surface) is ignored
/// by `min`/`max`; a texel with no surface under it stays NaN.
///
/// `finer` is level `level - 1` (at least its `width * height` texels),
/// `band` receives rows `rows` of level `level`, row stride = level width.
/// Different row bands of one level may be built concurrently.
///
/// # Errors
/// [`Error::InvalidArgument`] if `level` is 0 or not below
/// [`HiZLayout::level_count`], or `rows` exceed the level's height;
/// [`Error::InsufficientSize`] if `finer` or `band` is too short. Nothing is
/// written on error.
///
/// # Panics
/// Never.
pub fn try_build_hiz_level_rows(
    band: &mut [HiZTexel],
    finer: &[HiZTexel],
    layout: &HiZLayout,
    level: u32,
    rows: RowRange,
) -> Result<(), Error> {
    let (f, c) = layout.try_band_levels(level, rows, finer.len(), band.len())?;
    let cw = c.width as usize;
    let fw = f.width as usize;
    for (dst, y) in band.chunks_exact_mut(cw).zip(rows.rows()) {
        let ys = cell_children(y, c.height, f.height);
        // The common row: two finer rows, and every coarse texel but the
        // last folds exactly 2x2 texels. The set of texels folded is the
        // footprint's, and `min`/`max` ignoring NaN (no zeros: level 0
        // holds none) do not depend on the order, so the bits are those of
        // the general loop below, which does the rest.
        let mut done = 0;
        if ys.len() == 2 && cw >= 2 {
            let r0 = &finer[ys.start as usize * fw..][..2 * (cw - 1)];
            let r1 = &finer[(ys.start as usize + 1) * fw..][..2 * (cw - 1)];
            fold_2x2_row(&mut dst[..cw - 1], r0, r1);
            done = cw - 1;
        }
        for (x, o) in dst.iter_mut().enumerate().skip(done) {
            let xs = cell_children(x as u32, c.width, f.width);
            let (mut lo, mut hi) = (f32::NAN, f32::NAN);
            for yy in ys.clone() {
                let row = &finer[yy as usize * fw..];
                for t in &row[xs.start as usize..xs.end as usize] {
                    lo = lo.min(t[0]);
                    hi = hi.max(t[1]);
                }
            }
            *o = [lo, hi];
        }
    }
    Ok(())
}

/// The common 2x2 fold of [`try_build_hiz_level_rows`]: coarse texel `i`
/// of `dst` is the NaN-ignoring min and max ([`f32::min`], [`f32::max`]:
/// IEEE `minNum`/`maxNum`) of texels `2i, 2i + 1` of the finer rows `r0`
/// and `r1` (each at least `2 dst.len()` texels long).
///
/// On x86-64 four coarse texels at a time with SSE2 (the x86-64 baseline,
/// so no run-time dispatch): the same texels, the same values
/// ([`nan_min4`]), so the same bits as the scalar fold, which does the
/// tail and every other target. `tests/hiz.rs` checks both against a
/// brute-force fold.
#[inline]
fn fold_2x2_row(dst: &mut [HiZTexel], r0: &[HiZTexel], r1: &[HiZTexel]) {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    // SAFETY: `fold_rows` only requires SSE2, which this build enables
    // (the `cfg` above: `target_feature = "sse2"` at compile time, the
    // x86-64 baseline); calling a `#[target_feature]` function is `unsafe`
    // only for that reason. It reads and writes through safe slices.
    #[allow(unsafe_code)]
    let done = unsafe { sse2::fold_rows(dst, r0, r1) };
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    let done = 0;
    for ((o, a), b) in dst[done..]
        .iter_mut()
        .zip(r0[2 * done..].chunks_exact(2))
        .zip(r1[2 * done..].chunks_exact(2))
    {
        let lo = a[0][0].min(a[1][0]).min(b[0][0].min(b[1][0]));
        let hi = a[0][1].max(a[1][1]).max(b[0][1].max(b[1][1]));
        *o = [lo, hi];
    }
}

#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
#[allow(unsafe_code)]
mod sse2 {
    //! SSE2 (x86-64 baseline) lanes for the pyramid build: a function with
    //! `#[target_feature(enable = "sse2")]`, in which the intrinsics are
    //! safe. The one `unsafe` block is its loads (each with its bounds
    //! argument); stores go through the output slice.
    use super::HiZTexel;
    use core::arch::x86_64::{
        __m128, _mm_and_ps, _mm_andnot_ps, _mm_cmpunord_ps, _mm_cvtss_f32, _mm_loadu_ps,
        _mm_max_ps, _mm_min_ps, _mm_or_ps, _mm_shuffle_ps,
    };

    /// The fold of [`super::fold_2x2_row`] for the first multiple of four
    /// coarse texels of `dst`; returns how many it wrote. Four coarse
    /// texels at a time from eight texels of each finer row, in the scalar
    /// fold's order, `min(min(a0, a1), min(b0, b1))`, and with its values:
    ///
    /// * `_mm_min_ps(a, b)` is `a < b ? a : b` lane by lane, which ignores a
    ///   NaN `a` only; where `b` is NaN the fold takes `a`. That is `minNum`
    ///   of the lanes (NaN only if both are), the value of [`f32::min`];
    ///   `max` likewise.
    /// * A row's eight texels are split into the closest depths of the even
    ///   and of the odd texels and the farthest depths likewise
    ///   (`[c0 c2 c4 c6]`, `[c1 c3 c5 c7]`, ...) by shuffles.
    ///
    /// Written as one function body (macros, not helper functions): a
    /// `#[target_feature]` function cannot be `#[inline(always)]`, and
    /// helpers left out of line return their vectors through memory.
    #[target_feature(enable = "sse2")]
    pub(super) fn fold_rows(dst: &mut [HiZTexel], r0: &[HiZTexel], r1: &[HiZTexel]) -> usize {
        macro_rules! nan_fold {
            ($op:ident, $a:expr, $b:expr) => {{
                let (a, b) = ($a, $b);
                let b_nan = _mm_cmpunord_ps(b, b);
                _mm_or_ps(_mm_and_ps(b_nan, a), _mm_andnot_ps(b_nan, $op(a, b)))
            }};
        }
        macro_rules! split {
            ($t:expr) => {{
                let t: &[HiZTexel] = $t;
                debug_assert_eq!(t.len(), 8);
                let p = t.as_ptr().cast::<f32>();
                // SAFETY: `t` is a chunk of exactly eight texels, 16
                // contiguous f32 (`[f32; 2]` has no padding), so the four
                // unaligned 16-byte loads at floats 0, 4, 8 and 12 read
                // inside it.
                let (v0, v1, v2, v3) = unsafe {
                    (
                        _mm_loadu_ps(p),
                        _mm_loadu_ps(p.add(4)),
                        _mm_loadu_ps(p.add(8)),
                        _mm_loadu_ps(p.add(12)),
                    )
                };
                // [c0 c1 c2 c3], [f0 f1 f2 f3], [c4 .. c7], [f4 .. f7]
                let c03 = _mm_shuffle_ps::<0b10_00_10_00>(v0, v1);
                let f03 = _mm_shuffle_ps::<0b11_01_11_01>(v0, v1);
                let c47 = _mm_shuffle_ps::<0b10_00_10_00>(v2, v3);
                let f47 = _mm_shuffle_ps::<0b11_01_11_01>(v2, v3);
                (
                    _mm_shuffle_ps::<0b10_00_10_00>(c03, c47),
                    _mm_shuffle_ps::<0b11_01_11_01>(c03, c47),
                    _mm_shuffle_ps::<0b10_00_10_00>(f03, f47),
                    _mm_shuffle_ps::<0b11_01_11_01>(f03, f47),
                )
            }};
        }
        let n = dst.len() / 4 * 4;
        for ((o, a), b) in dst[..n]
            .chunks_exact_mut(4)
            .zip(r0.chunks_exact(8))
            .zip(r1.chunks_exact(8))
        {
            let (ace, aco, afe, afo) = split!(a);
            let (bce, bco, bfe, bfo) = split!(b);
            let lo = nan_fold!(
                _mm_min_ps,
                nan_fold!(_mm_min_ps, ace, aco),
                nan_fold!(_mm_min_ps, bce, bco)
            );
            let hi = nan_fold!(
                _mm_max_ps,
                nan_fold!(_mm_max_ps, afe, afo),
                nan_fold!(_mm_max_ps, bfe, bfo)
            );
            // Lanes out through `cvtss` (a store would need a pointer).
            let lane = |v: __m128, i: usize| {
                _mm_cvtss_f32(match i {
                    1 => _mm_shuffle_ps::<1>(v, v),
                    2 => _mm_shuffle_ps::<2>(v, v),
                    _ => _mm_shuffle_ps::<3>(v, v),
                })
            };
            o[0] = [_mm_cvtss_f32(lo), _mm_cvtss_f32(hi)];
            o[1] = [lane(lo, 1), lane(hi, 1)];
            o[2] = [lane(lo, 2), lane(hi, 2)];
            o[3] = [lane(lo, 3), lane(hi, 3)];
        }
        n
    }
}

/// Texels of the finer level folded into coarse texel `c` along one axis:
/// `[2c, 2c + 2)`, the last coarse texel reaching the finer edge.
#[inline]
fn cell_children(c: u32, coarse: u32, fine: u32) -> Range<u32> {
    // c < coarse = max(1, fine / 2), so 2c < fine.
    let hi = if c + 1 >= coarse { fine } else { 2 * c + 2 };
    2 * c..hi
}

/// Builds the whole pyramid of `depth` into `dst` (level by level, see
/// [`try_build_hiz_level0_rows`] and [`try_build_hiz_level_rows`] for the row-band
/// variants a threaded host uses) and stamps it with the depth image's
/// size and camera ([`PyramidStamp`]).
///
/// # Errors
/// [`Error::InsufficientSize`] if `dst` holds fewer than
/// [`try_hiz_len`]`(width, height)` texels. Nothing is written on error.
///
/// # Panics
/// Never.
pub fn try_build_hiz(dst: &mut [HiZTexel], depth: &DepthImage<'_>) -> Result<(), Error> {
    let layout = HiZLayout::try_new(depth.width(), depth.height())?;
    if dst.len() < try_hiz_len(depth.width(), depth.height())? {
        return Err(Error::InsufficientSize);
    }
    let l0 = layout.levels[0];
    try_build_hiz_level0_rows(&mut dst[l0.range()], depth, RowRange::try_all(l0.height)?)?;
    for level in 1..layout.count {
        let (f, c) = (
            layout.levels[level as usize - 1],
            layout.levels[level as usize],
        );
        let (head, tail) = dst.split_at_mut(c.offset);
        try_build_hiz_level_rows(
            &mut tail[..c.len()],
            &head[f.range()],
            &layout,
            level,
            RowRange::try_all(c.height)?,
        )?;
    }
    try_stamp_hiz(dst, depth.camera())
}

/// A built pyramid with the camera of its depth image: what [`try_trace_hiz`]
/// walks.
#[derive(Clone, Copy, Debug)]
pub struct HiZ<'a> {
    data: &'a [HiZTexel],
    layout: HiZLayout,
    camera: Camera,
    convention: DepthConvention,
    /// World to homogeneous pixel space, rows x, y and w (`w` = linear
    /// depth) of [`Camera::world_to_pixel`].
    to_pixel: Mat4,
    /// The level table as the traversal reads it, computed once here rather
    /// than per visited cell ([`CellLevel`]).
    cells: [CellLevel; MAX_LEVELS],
}

/// One pyramid level as the traversal reads it per visited cell: its first
/// texel, its last cell index along each axis (`width - 1`, `height - 1`)
/// and its row stride (`width`), the values [`Walker`]'s cell arithmetic
/// uses, so that no visit recomputes them.
#[derive(Clone, Copy, Debug, Default)]
struct CellLevel {
    offset: usize,
    last_x: u32,
    last_y: u32,
    width: usize,
}

impl<'a> HiZ<'a> {
    /// Binds a pyramid buffer (built by [`try_build_hiz`] from a depth image of
    /// `camera`) to its camera and the convention of that depth image (used
    /// only to decode [`Thickness::BackFaces`]).
    ///
    /// # Errors
    /// * [`Error::InsufficientSize`] if `data` holds fewer than
    ///   [`try_hiz_len`]`(camera.width(), camera.height())` texels.
    /// * [`Error::InvalidArgument`] if the pyramid's [`PyramidStamp`] is not
    ///   `camera`'s: built for another image size or another camera, or not
    ///   built (or not stamped, after a row-band build) at all.
    pub fn try_new(
        data: &'a [HiZTexel],
        camera: Camera,
        convention: DepthConvention,
    ) -> Result<Self, Error> {
        let layout = HiZLayout::try_new(camera.width(), camera.height())?;
        if data.len() < try_hiz_len(camera.width(), camera.height())? {
            return Err(Error::InsufficientSize);
        }
        if PyramidStamp::read(data, camera.width(), camera.height())
            != Some(PyramidStamp::of(&camera))
        {
            return Err(Error::InvalidArgument);
        }
        // The x, y and w rows do not depend on the depth convention.
        let to_pixel = camera.try_world_to_pixel(DepthConvention::ZeroToOne)?;
        let mut cells = [CellLevel::default(); MAX_LEVELS];
        for (c, l) in cells
            .iter_mut()
            .zip(&layout.levels[..layout.count as usize])
        {
            *c = CellLevel {
                offset: l.offset,
                last_x: l.width - 1,
                last_y: l.height - 1,
                width: l.width as usize,
            };
        }
        Ok(Self {
            data,
            layout,
            camera,
            convention,
            to_pixel,
            cells,
        })
    }

    /// The pyramid's layout.
    pub const fn layout(&self) -> &HiZLayout {
        &self.layout
    }

    /// The camera of the depth image.
    pub const fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The convention of the depth image (and of back-face images).
    pub const fn convention(&self) -> DepthConvention {
        self.convention
    }

    /// Texel `(x, y)` of level `level`: `[closest, farthest]` linear depth,
    /// or `None` outside the pyramid.
    pub fn texel(&self, level: u32, x: u32, y: u32) -> Option<HiZTexel> {
        let l = self.layout.level(level)?;
        if x >= l.width || y >= l.height {
            return None;
        }
        self.data
            .get(l.offset + y as usize * l.width as usize + x as usize)
            .copied()
    }
}

/// Settings of [`try_trace_hiz`]. Every setting returns the same exact first
/// hit (up to f32 rounding); they trade loop iterations for fetches.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct HiZOptions {
    /// Level the hierarchical walk starts at after the prologue (seed 004
    /// Listing 4.5, `HIZ_START_LEVEL`, 2 in the seed's demo). Clamped to
    /// the last level, and raised to `stop_level` if below it.
    pub start_level: u32,
    /// Finest level of the hierarchical walk. `0` resolves hits in the
    /// hierarchy itself; `L > 0` resolves a level-`L` cell that may hold a
    /// hit by unit steps through its pixels (Sec. 4.7.1), which stays exact.
    /// Clamped to the last level.
    pub stop_level: u32,
    /// Cap on hierarchical loop iterations (Listing 4.5, `MAX_ITERATIONS`);
    /// reaching it is [`Miss::OutOfSteps`]. The prologue and the unit steps
    /// below `stop_level` are bounded by their own lengths, not by this cap.
    pub max_iterations: u32,
    /// Unit (one-pixel) steps before the hierarchy (Sec. 4.7.1). `u32::MAX`
    /// gives plain per-pixel stepping.
    pub prologue_steps: u32,
}

impl Default for HiZOptions {
    /// Start at level 2 as the seed's demo, stop at level 0 (exact), 4
    /// prologue steps, at most 1024 iterations.
    fn default() -> Self {
        Self {
            start_level: 2,
            stop_level: 0,
            max_iterations: 1024,
            prologue_steps: 4,
        }
    }
}

/// Diagnostic counters of one traversal, beyond the shared [`Work`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct HiZStats {
    /// Cell selections where `floor` of the ray position picked a different
    /// cell than the one the ray is entering: the ray sat exactly on a cell
    /// boundary (or rounded back across it). Position-based cell lookup
    /// (seed 004 Listing 4.5 `getCell`) stalls there; the frontier walk
    /// advances.
    pub boundary_ties: u32,
    /// Highest level the walk reached.
    pub max_level: u32,
}

/// Traces `ray` over `[0, t_max]` against the Hi-Z pyramid (seed 004
/// Sec. 4.4.3, Listings 4.2/4.5, with the extensions of Sec. 4.6.6, 4.6.7
/// and 4.7.1; see the module docs). Returns the first point of the ray, in
/// ray order, whose linear depth lies in a texel's hit slab, or the reason
/// for a miss.
///
/// The hit's `t` is consistent with [`Ray::at`]: `ray.at(t)` projects to
/// `pixel` at linear depth `depth` (up to f32 rounding); `pixel.floor()` is
/// the texel hit and `surface_depth` its front depth.
///
/// Misses: [`Miss::BehindGeometry`] if the segment ended (or left the
/// image) while its end point lay behind the hit slab of the texel there;
/// otherwise [`Miss::LeftImage`] when it left through a side of the image
/// or the near plane (a ray coming toward the camera), [`Miss::EndOfRay`]
/// at `t_max`, the far plane or the vanishing point;
/// [`Miss::OutOfSteps`] at [`HiZOptions::max_iterations`];
/// [`Miss::DegenerateProjection`] if no part of the ray lies in the view
/// frustum.
///
/// # Errors
/// [`Error::InvalidArgument`] for a ray or `t_max` rejected by
/// [`try_validate_ray`], a negative or NaN constant
/// thickness, or a back-face image whose size differs from the pyramid's.
///
/// # Panics
/// Never.
pub fn try_trace_hiz(
    hiz: &HiZ<'_>,
    thickness: Thickness<'_>,
    ray: Ray,
    t_max: f32,
    options: &HiZOptions,
) -> Result<Trace, Error> {
    try_trace_hiz_stats(hiz, thickness, ray, t_max, options).map(|(t, _)| t)
}

/// [`try_trace_hiz`] that also returns its [`HiZStats`].
///
/// # Errors
/// As [`try_trace_hiz`].
///
/// # Panics
/// Never.
pub fn try_trace_hiz_stats(
    hiz: &HiZ<'_>,
    thickness: Thickness<'_>,
    ray: Ray,
    t_max: f32,
    options: &HiZOptions,
) -> Result<(Trace, HiZStats), Error> {
    try_validate_ray(&ray, t_max)?;
    validate_thickness(hiz, &thickness)?;
    Ok(trace_valid::<true>(hiz, thickness, &ray, t_max, options))
}

/// Traces `rays[i]` with maximum distance `t_max[i]` (or `t_max[0]` for
/// every ray when `t_max.len() == 1`) into `out[i]`, as [`try_trace_hiz`]
/// would (the same arguments in the same order, the ray and `t_max`
/// replaced by slices, the result by `out`). For threads, split `rays`,
/// `out` (and `t_max`) into matching chunks and call this on each.
///
/// `out` holds [`Trace`]s or any type made from one (`From<Trace>`), and
/// `rays` [`Ray`]s or any type that converts into one: a host's (or the C
/// ABI's) own ray and result records are traced in place, without a copy.
///
/// # Errors
/// * [`Error::InsufficientSize`]: `out.len() < rays.len()`, or `t_max` is
///   neither of length 1 nor at least `rays.len()` long.
/// * [`Error::InvalidArgument`]: `t_max` is empty, or any ray, `t_max` or
///   the thickness is rejected as by [`try_trace_hiz`].
///
/// Every input is validated before anything is written; on `Err`, `out` is
/// untouched.
///
/// # Panics
/// Never.
pub fn try_trace_hiz_rays<O: From<Trace>, R: Copy + Into<Ray>>(
    out: &mut [O],
    hiz: &HiZ<'_>,
    thickness: Thickness<'_>,
    rays: &[R],
    t_max: &[f32],
    options: &HiZOptions,
) -> Result<(), Error> {
    validate_batch(out.len(), hiz, &thickness, rays, t_max)?;
    match thickness {
        Thickness::Constant(th) => trace_constant(out, hiz, &[th], rays, t_max, options),
        Thickness::BackFaces(_) => trace_rays_scalar(out, hiz, thickness, rays, t_max, options),
    }
    Ok(())
}

/// [`try_trace_hiz_rays`] with a constant thickness per ray,
/// `thickness[i]` for `rays[i]`: what a pass whose thickness scales with
/// each pixel's depth hands the walk (`crate::ssr`). Validates as
/// [`try_trace_hiz_rays`] (every thickness as a constant one) and writes
/// nothing on `Err`.
pub(crate) fn try_trace_hiz_rays_thick(
    out: &mut [Trace],
    hiz: &HiZ<'_>,
    thickness: &[f32],
    rays: &[Ray],
    t_max: &[f32],
    options: &HiZOptions,
) -> Result<(), Error> {
    if out.len() < rays.len() || thickness.len() < rays.len() || t_max.len() < rays.len() {
        return Err(Error::InsufficientSize);
    }
    for ((r, &tm), &th) in rays.iter().zip(t_max).zip(thickness) {
        try_validate_ray(r, tm)?;
        if !(th >= 0.0) {
            return Err(Error::InvalidArgument);
        }
    }
    trace_constant(out, hiz, thickness, rays, t_max, options);
    Ok(())
}

/// `v[i]` of a per-ray argument given once for every ray (`v.len() == 1`)
/// or once per ray.
#[inline]
fn per_ray(v: &[f32], i: usize) -> f32 {
    if v.len() == 1 {
        v[0]
    } else {
        v[i]
    }
}

/// Traces validated rays with constant thicknesses `th` (and `t_max`; each
/// [`per_ray`]): the AVX2 stream where it runs and takes the batch, else the
/// scalar walk ray by ray.
fn trace_constant<O: From<Trace>, R: Copy + Into<Ray>>(
    out: &mut [O],
    hiz: &HiZ<'_>,
    th: &[f32],
    rays: &[R],
    t_max: &[f32],
    options: &HiZOptions,
) {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    if avx2::available() && avx2::takes(hiz, options, rays.len()) {
        // SAFETY: `available` checked that the CPU runs AVX2.
        #[allow(unsafe_code)]
        unsafe {
            avx2::trace_rays(out, hiz, th, rays, t_max, options);
        }
        return;
    }
    for (i, (o, r)) in out.iter_mut().zip(rays).enumerate() {
        let thickness = Thickness::Constant(per_ray(th, i));
        *o = trace_valid::<false>(hiz, thickness, &(*r).into(), per_ray(t_max, i), options)
            .0
            .into();
    }
}

/// Lanes [`try_trace_hiz_rays`] walks at once on this CPU: 8 where the
/// AVX2 ray stream runs (x86-64 with AVX2, detected at run time), else 1
/// (the scalar walk). Results are the same bits either way; this only
/// says which loop runs, for benchmarks and logs.
pub fn hiz_stream_lanes() -> usize {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    if avx2::available() {
        return 8;
    }
    1
}

/// [`try_trace_hiz_rays`] with the scalar walk for every ray, never the
/// AVX2 stream: the stream's reference, and what `try_trace_hiz_rays` does
/// on CPUs without AVX2. Same results, bit for bit.
///
/// # Errors
/// As [`try_trace_hiz_rays`].
///
/// # Panics
/// Never.
pub fn try_trace_hiz_rays_scalar<O: From<Trace>, R: Copy + Into<Ray>>(
    out: &mut [O],
    hiz: &HiZ<'_>,
    thickness: Thickness<'_>,
    rays: &[R],
    t_max: &[f32],
    options: &HiZOptions,
) -> Result<(), Error> {
    validate_batch(out.len(), hiz, &thickness, rays, t_max)?;
    trace_rays_scalar(out, hiz, thickness, rays, t_max, options);
    Ok(())
}

/// The checks of [`try_trace_hiz_rays`], before anything is written.
fn validate_batch<R: Copy + Into<Ray>>(
    out_len: usize,
    hiz: &HiZ<'_>,
    thickness: &Thickness<'_>,
    rays: &[R],
    t_max: &[f32],
) -> Result<(), Error> {
    if t_max.is_empty() {
        return Err(Error::InvalidArgument);
    }
    if out_len < rays.len() || (t_max.len() != 1 && t_max.len() < rays.len()) {
        return Err(Error::InsufficientSize);
    }
    validate_thickness(hiz, thickness)?;
    for (i, r) in rays.iter().enumerate() {
        try_validate_ray(&(*r).into(), per_ray(t_max, i))?;
    }
    Ok(())
}

/// The scalar batch walk over validated rays.
fn trace_rays_scalar<O: From<Trace>, R: Copy + Into<Ray>>(
    out: &mut [O],
    hiz: &HiZ<'_>,
    thickness: Thickness<'_>,
    rays: &[R],
    t_max: &[f32],
    options: &HiZOptions,
) {
    for (i, (o, r)) in out.iter_mut().zip(rays).enumerate() {
        *o = trace_valid::<false>(hiz, thickness, &(*r).into(), per_ray(t_max, i), options)
            .0
            .into();
    }
}

fn validate_thickness(hiz: &HiZ<'_>, thickness: &Thickness<'_>) -> Result<(), Error> {
    match thickness {
        Thickness::Constant(t) if !(*t >= 0.0) => Err(Error::InvalidArgument),
        Thickness::BackFaces(v)
            if v.width() != hiz.layout.width || v.height() != hiz.layout.height =>
        {
            Err(Error::InvalidArgument)
        }
        _ => Ok(()),
    }
}

/// The clipped ray in screen space: `P(s) = P0 + s D`, `s` in `[0, 1]`,
/// with `P = (pixel x, pixel y, q = 1 / z)`.
#[derive(Clone, Copy, Debug)]
struct Segment {
    x0: f32,
    y0: f32,
    q0: f32,
    dx: f32,
    dy: f32,
    dq: f32,
    q1: f32,
    /// Ray parameter at `s = 0`.
    t0: f32,
    /// Ray parameter at `s = 1` (may be `+inf`).
    t1: f32,
    /// `t(s) = t0 + s k / q(s)` (perspective-correct interpolation).
    k: f32,
    /// Linear depth of the ray's origin and its rate along the ray: the ray
    /// is at depth `ow + t dw`.
    ow: f32,
    dw: f32,
    /// The segment ends on a side of the view frustum or the near plane
    /// (left the image).
    ends_on_side: bool,
}

impl Segment {
    #[inline]
    fn x(&self, s: f32) -> f32 {
        self.x0 + s * self.dx
    }
    #[inline]
    fn y(&self, s: f32) -> f32 {
        self.y0 + s * self.dy
    }
    /// `q` at `s`, exact at both ends: `q0 + s dq` loses `q1` entirely when
    /// `q0` is huge (a near plane of 1.6e-33 clipping a ray that starts at
    /// the eye, found by the hiz fuzz target: a hit at `s = 1` with depth
    /// `1 / 0 = inf`).
    #[inline]
    fn q(&self, s: f32) -> f32 {
        self.q0 * (1.0 - s) + self.q1 * s
    }
}

/// Clips `t` in `[lo, hi]` to the half-space `a + b t >= 0`.
#[inline]
fn clip(lo: &mut f32, hi: &mut f32, side: &mut bool, a: f32, b: f32, is_side: bool) -> bool {
    if b > 0.0 {
        let t = -a / b;
        if t > *lo {
            *lo = t;
        }
    } else if b < 0.0 {
        let t = -a / b;
        if t < *hi {
            *hi = t;
            *side = is_side;
        }
    } else if !(a >= 0.0) {
        return false;
    }
    true
}

/// Projects and clips the ray (seed 004 Sec. 4.4.3: the ray as
/// `O + D t` in screen space, here clipped to the frustum in homogeneous
/// pixel space so that rays toward infinity end at their vanishing point).
fn project_segment(hiz: &HiZ<'_>, ray: &Ray, t_max: f32) -> Option<Segment> {
    let m = &hiz.to_pixel;
    let o = *m * Vec4::new(ray.origin.x, ray.origin.y, ray.origin.z, 1.0);
    let d = *m * Vec4::new(ray.dir.x, ray.dir.y, ray.dir.z, 0.0);
    let (wf, hf) = (hiz.layout.width as f32, hiz.layout.height as f32);
    let (n, f) = (hiz.camera.near(), hiz.camera.far());
    let (mut lo, mut hi, mut side) = (0.0f32, t_max, false);
    let ok = clip(&mut lo, &mut hi, &mut side, o.w - n, d.w, true)
        && (f.is_infinite() || clip(&mut lo, &mut hi, &mut side, f - o.w, -d.w, false))
        && clip(&mut lo, &mut hi, &mut side, o.x, d.x, true)
        && clip(
            &mut lo,
            &mut hi,
            &mut side,
            wf * o.w - o.x,
            wf * d.w - d.x,
            true,
        )
        && clip(&mut lo, &mut hi, &mut side, o.y, d.y, true)
        && clip(
            &mut lo,
            &mut hi,
            &mut side,
            hf * o.w - o.y,
            hf * d.w - d.y,
            true,
        );
    if !ok || !(lo <= hi) || !lo.is_finite() {
        return None;
    }
    // Start point: plain homogeneous divide.
    let w0 = o.w + lo * d.w;
    let (x0, y0, q0) = ((o.x + lo * d.x) / w0, (o.y + lo * d.y) / w0, 1.0 / w0);
    // End point and k = (t1 - t0) q1, scaled by l = 1 / t1 for long (or
    // infinite) segments so that the end stays finite.
    let (x1, y1, q1, k) = if hi <= 1.0 {
        let w1 = o.w + hi * d.w;
        (
            (o.x + hi * d.x) / w1,
            (o.y + hi * d.y) / w1,
            1.0 / w1,
            (hi - lo) / w1,
        )
    } else {
        let l = 1.0 / hi;
        let ws = o.w * l + d.w;
        (
            (o.x * l + d.x) / ws,
            (o.y * l + d.y) / ws,
            l / ws,
            (1.0 - lo * l) / ws,
        )
    };
    if !(w0 > 0.0) || !(q1 >= 0.0) || !(k >= 0.0) {
        return None;
    }
    let (x0, y0, x1, y1) = (
        x0.clamp(0.0, wf),
        y0.clamp(0.0, hf),
        x1.clamp(0.0, wf),
        y1.clamp(0.0, hf),
    );
    let seg = Segment {
        x0,
        y0,
        q0,
        dx: x1 - x0,
        dy: y1 - y0,
        dq: q1 - q0,
        q1,
        t0: lo,
        t1: hi,
        k,
        ow: o.w,
        dw: d.w,
        ends_on_side: side,
    };
    let finite = [seg.x0, seg.y0, seg.q0, seg.dx, seg.dy, seg.dq, seg.k]
        .iter()
        .all(|v| v.is_finite());
    finite.then_some(seg)
}

// Rounding to integers without libm. In `no_std` (x86-64 baseline, no
// SSE4.1 `roundss`) `libm::floorf`/`ceilf` are out-of-line software calls;
// the walk rounds several coordinates per cell, so these were a measurable
// part of its cost. A truncating conversion (`cvttss2si`) plus a one-step
// fix-up is exact for every f32: `v as i64` is `trunc(v)`, which is itself
// an f32 value, so `(v as i64) as f32` is exact and compares exactly with
// `v`; `as` saturates outside the i64 range and maps NaN to 0, as
// `floorf(v) as i64` does (the fix-up saturates too).

/// `libm::floorf(v) as i64`, for every f32 `v` (see above).
#[inline]
fn floor_i64(v: f32) -> i64 {
    let i = v as i64;
    i.saturating_sub(i64::from((i as f32) > v))
}

// Pixel indices need less: a pixel is clamped into `0..size` with
// `size <= u32::MAX`, so every rounding below 0 or above `u32::MAX - 1` ends
// in the same pixel. `v as u32` alone (one conversion with its saturation,
// no fix-up) is `trunc(v) = floor(v)` for `0 <= v < 2^32`, 0 for negative
// and NaN `v`, `u32::MAX` from `2^32` on.

/// `floor(v)` for `0 <= v < 2^32`; 0 below (and for NaN), `u32::MAX` above.
#[inline(always)]
fn floor_sat(v: f32) -> u32 {
    v as u32
}

/// `ceil(v)` for `0 <= v < 2^32` (as [`floor_sat`]: `trunc(v)` is an f32
/// value, so it compares exactly with `v`); 0 for `v <= 0` and NaN, at least
/// `u32::MAX` from `2^32` on.
#[inline(always)]
fn ceil_sat(v: f32) -> i64 {
    let c = v as u32;
    i64::from(c) + i64::from((c as f32) < v)
}

/// Pixel of coordinate `v` for motion `d` along an axis of `size >= 1`
/// pixels, clamped into `0..size`: `floor(v)`, or `ceil(v) - 1` when moving
/// toward smaller coordinates (a position on a boundary belongs to the
/// pixel the ray is entering). [`floor_sat`] / [`ceil_sat`] are exact where
/// the clamp does not decide.
#[inline]
fn dir_pixel(v: f32, d: f32, size: u32) -> u32 {
    let last = size - 1;
    if d < 0.0 {
        (ceil_sat(v) - 1).clamp(0, i64::from(last)) as u32
    } else {
        floor_sat(v).min(last)
    }
}

/// The largest f32 below `i + 1`, for clamping a position into pixel `i`.
#[inline]
fn below(i: u32) -> f32 {
    let v = (i as f32) + 1.0;
    f32::from_bits(v.to_bits() - 1)
}

/// `a.max(b)` for a non-NaN `a`: `b` if `b > a`, else `a`, so a NaN `b` is
/// ignored as by [`f32::max`]. One `maxss`, where `f32::max` also has to
/// handle a NaN `a`. When `a` and `b` are zeros of opposite signs, where
/// `f32::max` leaves the result unspecified, this returns `a`, as the
/// x86-64 lowering of `a.max(b)` does; otherwise both are the same value.
#[inline(always)]
fn max_nn(a: f32, b: f32) -> f32 {
    if b > a {
        b
    } else {
        a
    }
}

/// `a.min(b)` for a non-NaN `a`, as [`max_nn`].
#[inline(always)]
fn min_nn(a: f32, b: f32) -> f32 {
    if b < a {
        b
    } else {
        a
    }
}

/// A cell of some level, as the walk needs it: its indices, along each axis
/// the *edge pixel*, the last level-0 pixel of the cell in that axis's
/// direction of motion, and the index of its texel in the pyramid buffer.
/// In level-0 pixels cell `x` of level `L` spans `[x0, x1)` with
/// `x0 = x 2^L` and `x1 = (x + 1) 2^L`, or the image edge for the last cell;
/// its edge pixel is `x1 - 1` moving toward `+x` and `x0` moving toward `-x`,
/// the only side the segment can leave through. Plain integers, so that it
/// is `Copy` and stays in registers.
#[derive(Clone, Copy, Debug)]
struct Cell {
    level: u32,
    x: u32,
    y: u32,
    ex: u32,
    ey: u32,
    index: usize,
}

enum Step {
    /// Hit at `s` on the surface at linear depth `surface` (level 0).
    Hit { s: f32, surface: f32 },
    /// Crossed into the next cell.
    Next,
    /// The segment ended (or left the image).
    End,
    /// The cell may hold a hit in `[sa, sb]` (levels > 0 only).
    Inside { cell: Cell, sa: f32, sb: f32 },
}

/// One screen axis of the segment, `v(s) = v0 + s d`, specialized on its
/// direction of motion: `NEG` for `d < 0`. An axis the segment does not move
/// along (`d == 0`, either sign) has `NEG = false`: its exit parameter is
/// `+inf` and its frontier pixel never changes ([`Self::sync`]).
#[derive(Clone, Copy, Debug)]
struct Axis<const NEG: bool> {
    v0: f32,
    d: f32,
    /// `v0` and `d` for [`Self::exit`]: the same when the segment moves
    /// along the axis, else `-inf` and `+0`, which make the exit parameter
    /// `(boundary + inf) / +0 = +inf` without a branch.
    exit_v0: f32,
    exit_d: f32,
    /// Level-0 size (pixels) along the axis.
    size: u32,
}

impl<const NEG: bool> Axis<NEG> {
    fn new(v0: f32, d: f32, size: u32) -> Self {
        let moves = d != 0.0;
        Self {
            v0,
            d,
            exit_v0: if moves { v0 } else { f32::NEG_INFINITY },
            exit_d: if moves { d } else { 0.0 },
            size,
        }
    }

    /// The coordinate at `s`, as [`Segment::x`] / [`Segment::y`].
    #[inline(always)]
    fn at(&self, s: f32) -> f32 {
        self.v0 + s * self.d
    }

    /// The edge pixel (see [`Cell`]) of cell `c <= last` of level `level`,
    /// whose last cell along the axis is `last`. As `cell_span`: `c << level
    /// <= p` for the frontier pixel `p` and, below the last cell, `(c + 1)
    /// << level <= size`, so the shifts do not overflow.
    #[inline(always)]
    fn edge(&self, c: u32, level: u32, last: u32) -> u32 {
        if NEG {
            c << level
        } else if c >= last {
            self.size - 1
        } else {
            ((c + 1) << level) - 1
        }
    }

    /// Where the segment leaves the cell whose edge pixel is `e`: the
    /// parameter of the cell side past `e`, `(boundary - v0) / d` (seed 004
    /// Listing 4.5, `intersectCellBoundary`, with the boundary in integer
    /// pixels), or `+inf` when the segment does not move along the axis.
    /// Never NaN: `d != 0` and both terms are finite, or `+inf / +0`.
    #[inline(always)]
    fn exit(&self, e: u32) -> f32 {
        let b = if NEG { e } else { e + 1 };
        (b as f32 - self.exit_v0) / self.exit_d
    }

    /// The pixel past edge pixel `e` in the direction of motion, or `None`
    /// past the image edge.
    #[inline(always)]
    fn next(&self, e: u32) -> Option<u32> {
        if NEG {
            e.checked_sub(1)
        } else {
            (e + 1 < self.size).then_some(e + 1)
        }
    }

    /// Moves the frontier along the axis from pixel `p` to the pixel of
    /// coordinate `v = v(s)`, kept inside the cell whose edge pixel is `e`
    /// (the cell holds `p`) and never backward.
    ///
    /// A pixel owns the segment up to and including its exit parameter as
    /// [`Self::exit`] computes it (`(boundary - v0) / d`), which is what a
    /// level-0 visit searches. The position `v` is rounded in f32 and may
    /// already lie on or past the boundary while `s` is still within the
    /// old pixel's exit: the frontier then stays in the old pixel, so a hit
    /// in its last sliver (a zero-thickness slab touched as the ray leaves
    /// the texel, found by exploration) is not stepped over.
    ///
    /// Rounding is toward the direction of motion: `floor(v)`, or
    /// `ceil(v) - 1` moving toward `-v` (a position on a boundary belongs to
    /// the pixel the ray is entering, [`dir_pixel`]). Clamping into the cell
    /// needs only its edge pixel: the cell's other end lies behind `p`.
    /// The rounding is [`floor_sat`] / [`ceil_sat`]: they differ from exact
    /// rounding only below 0 and from `2^32` on, where the clamp into the
    /// pixels between `p` and `e` (both in `0..u32::MAX`) gives the same
    /// pixel (after the one-pixel exit check, which then also lands below
    /// or above that range).
    ///
    /// An axis the segment does not move along needs no test of its own:
    /// `v = v0` and `p = min(floor(v0), size - 1)` ([`dir_pixel`] with
    /// `NEG = false`), so `f > p` only for `v0 = size`, where `p = size - 1`
    /// is the last pixel and so its own cell's edge `e`; the clamp returns
    /// `p` (and the one-pixel check divides by `d = +-0`, harmlessly).
    #[inline(always)]
    fn sync(&self, s: f32, v: f32, p: u32, e: u32) -> u32 {
        // The position still in pixel `p` (the common case): `p` without
        // a conversion (see `Self::sync_stays`).
        if self.sync_stays(v, p) {
            return p;
        }
        if NEG {
            let p = i64::from(p);
            let mut f = ceil_sat(v) - 1;
            if f < p && s <= ((f + 1) as f32 - self.v0) / self.d {
                f += 1;
            }
            f.min(p).max(i64::from(e)) as u32
        } else {
            let mut f = floor_sat(v);
            if f > p && s <= (f as f32 - self.v0) / self.d {
                f -= 1;
            }
            f.max(p).min(e)
        }
    }

    /// Whether [`Self::sync`] from pixel `p` to position `v` returns `p`
    /// (the frontier's cell lookup, the exact form of seed 004 Listing 4.5's
    /// `getCell`, see the module docs) because `v` has not passed `p`'s far
    /// side: `v < p + 1` moving toward
    /// `+v`, `v > p` moving toward `-v`, compared in f32 (`p + 1` and `p`
    /// rounded to f32: between a rounded integer and the integer itself
    /// lies no other f32, so `v < fl(p + 1)` still gives `floor(v) <= p`
    /// and `v > fl(p)` gives `ceil(v) - 1 >= p`). The full sync then
    /// computes `f <= p` (`>= p`), skips the exit check and clamps to `p`,
    /// as `p` lies in the cell. `false` for a NaN `v`, which takes the
    /// full path.
    #[inline(always)]
    fn sync_stays(&self, v: f32, p: u32) -> bool {
        if NEG {
            v > p as f32
        } else {
            v < (p + 1) as f32
        }
    }
}

/// What changes along one ray's walk: the parameter `s` reached, the
/// frontier pixel `(px, py)` and the counters. A local of [`Walker::run`]
/// passed by `&mut` only to inlined steps (and by value to the hit and miss
/// builders), so that it lives in registers.
#[derive(Clone, Copy, Debug)]
struct State {
    s: f32,
    px: u32,
    py: u32,
    /// [`Work`] counters, saturated to `u32` on return.
    steps: u64,
    /// The fetches outside the hierarchical loop (prologue and unit-step
    /// visits, back-face texels, the end texel). Each hierarchical
    /// iteration visits exactly one cell, so [`Work::fetches`] is this plus
    /// `iterations`, not a counter kept per visit.
    fetches: u64,
    iterations: u32,
    stats: HiZStats,
}

impl State {
    fn work(&self) -> Work {
        let fetches = self.fetches + u64::from(self.iterations);
        Work {
            steps: u32::try_from(self.steps).unwrap_or(u32::MAX),
            fetches: u32::try_from(fetches).unwrap_or(u32::MAX),
            iterations: self.iterations,
        }
    }
}

/// What is constant along one ray's walk: the segment, its direction
/// class, the level table, the image size, the thickness, all read and
/// classified once here, not per cell. The loop is monomorphized per class:
///
/// * `NX`, `NY`: the segment moves toward `-x` / `-y` ([`Axis`]): a cell's
///   exit side, the pixel past it and the frontier's rounding are chosen at
///   compile time.
/// * `NQ`: `dq < 0`, `q` decreases (the ray moves away from the camera):
///   which slab bound the segment enters first.
/// * `BACK`: [`Thickness::BackFaces`] (else [`Thickness::Constant`]).
/// * `STATS`: whether to keep the [`HiZStats`] counters (the batch entry
///   point drops them, so it does not pay for them).
struct Walker<
    'h,
    'a,
    const NX: bool,
    const NY: bool,
    const NQ: bool,
    const BACK: bool,
    const STATS: bool,
> {
    hiz: &'h HiZ<'a>,
    levels: &'h [CellLevel; MAX_LEVELS],
    data: &'a [HiZTexel],
    seg: Segment,
    ax: Axis<NX>,
    ay: Axis<NY>,
    /// `q` at `s = 0` and `dq`.
    q0: f32,
    dq: f32,
    thickness: Thickness<'a>,
    /// The constant thickness (unused with `BACK`).
    th: f32,
    far: f32,
}

impl<const NX: bool, const NY: bool, const NQ: bool, const BACK: bool, const STATS: bool>
    Walker<'_, '_, NX, NY, NQ, BACK, STATS>
{
    /// The level table entry of `level` (`< level_count <= MAX_LEVELS`).
    #[inline(always)]
    fn level(&self, level: u32) -> CellLevel {
        self.levels[level as usize % MAX_LEVELS]
    }

    /// The cell of level `level` that holds the frontier.
    #[inline(always)]
    fn cell(&self, st: &State, level: u32) -> Cell {
        let l = self.level(level);
        let x = (st.px >> level).min(l.last_x);
        let y = (st.py >> level).min(l.last_y);
        Cell {
            level,
            x,
            y,
            ex: self.ax.edge(x, level, l.last_x),
            ey: self.ay.edge(y, level, l.last_y),
            index: l.offset + y as usize * l.width + x as usize,
        }
    }

    /// Whether the frontier lies in cell `c`: it has not passed the cell's
    /// edge pixels. The frontier only moves forward along each axis and `c`
    /// held it once (a cell the walk visited), so this is `(px, py)` in
    /// `c`'s span.
    #[inline(always)]
    fn holds(&self, st: &State, ex: u32, ey: u32) -> bool {
        let in_x = if NX { st.px >= ex } else { st.px <= ex };
        let in_y = if NY { st.py >= ey } else { st.py <= ey };
        in_x && in_y
    }

    /// The texel at `index`. Not counted here: the callers count their
    /// fetches ([`State::fetches`]).
    #[inline(always)]
    fn fetch(&self, index: usize) -> HiZTexel {
        self.data.get(index).copied().unwrap_or([f32::NAN; 2])
    }

    /// The far end of the hit slab of texel `[zmin, zmax]` of cell
    /// `(level, x, y)`: `farthest + thickness`, at level 0 the texel's own
    /// `z_front + thickness` or its back-face depth (read here, counted as a
    /// fetch; a NaN back texel or one in front of `z_front` gives `z_front`),
    /// above level 0 with back faces `+inf`. `zmin` is not NaN.
    #[inline(always)]
    fn upper(&self, st: &mut State, level: u32, x: u32, y: u32, zmin: f32, zmax: f32) -> f32 {
        if BACK {
            if level != 0 {
                return f32::INFINITY;
            }
            st.fetches += 1;
            let zb = match self.thickness {
                Thickness::BackFaces(back) => back
                    .get(x, y)
                    .map(|d| self.hiz.camera.decode_depth(d, self.hiz.convention))
                    .unwrap_or(f32::NAN),
                Thickness::Constant(_) => f32::NAN,
            };
            if zb >= zmin {
                zb
            } else {
                zmin
            }
        } else if level == 0 {
            zmin + self.th
        } else {
            // Sec. 4.6.6: farthest + thickness. `zmax.max(zmin)` for a
            // non-NaN `zmin` (`zmin` for a NaN `zmax`), one `maxss`: when the two are equal they are the
            // same bits (depths are positive or infinite, never `-0`).
            max_nn(zmin, zmax) + self.th
        }
    }

    /// The part of `[st.s, to]` where the segment lies in the hit slab of
    /// the cell's texel `[zmin, zmax]`: `q` in `[1 / upper, 1 / closest]`
    /// ([`Self::upper`]; level 0: the texel's own slab), or `None` if the
    /// slab is empty there or the texel has no hittable surface (NaN, or
    /// background at or beyond the far plane).
    ///
    /// Entering the slab is the "minimum depth plane" of Listing 4.2 for a
    /// segment moving away from the camera (`dq < 0`: `q` reaches
    /// `1 / closest` first), the farthest plane for one moving toward it
    /// (Sec. 4.6.7). With `dq == 0` (`+0`: `q0 > 0`, so never `-0`) the
    /// divisions give `+-inf` or NaN, and [`max_nn`] / [`min_nn`] turn
    /// them into "all of `[st.s, to]` if `q0` lies in the slab, else
    /// nothing" exactly as testing `q0` would.
    #[inline(always)]
    fn slab(&self, st: &mut State, c: &Cell, zmin: f32, zmax: f32, to: f32) -> Option<(f32, f32)> {
        if !(zmin < self.far) {
            return None;
        }
        let upper = self.upper(st, c.level, c.x, c.y, zmin, zmax);
        let (za, zb) = if NQ { (zmin, upper) } else { (upper, zmin) };
        let a = max_nn(st.s, (1.0 / za - self.q0) / self.dq);
        // Entered past `to`: empty whatever `b` is (`b <= to`). Tested
        // before `b` is computed, which also keeps the two sides scalar
        // (as one two-lane vector they cost more instructions in shuffles).
        if a > to {
            return None;
        }
        let b = min_nn(to, (1.0 / zb - self.q0) / self.dq);
        (a <= b).then_some((a, b))
    }

    /// Counts a boundary tie: `floor(v)` is not the pixel `n` the frontier
    /// moved to.
    #[inline(always)]
    fn tie(st: &mut State, v: f32, n: u32) {
        if STATS && floor_i64(v) != i64::from(n) && v.is_finite() {
            st.stats.boundary_ties = st.stats.boundary_ties.saturating_add(1);
        }
    }

    /// Moves the frontier to the ray position at `st.s` inside cell `c`.
    ///
    /// At the `s` where the frontier was last set (the start, a crossing, or
    /// a previous `sync_in`) this leaves it unchanged, so a descent whose
    /// slab entry is not past `s` skips it. An axis synced at `s` is a fixed
    /// point (same `floor`, same one-pixel exit check, and the cell holds
    /// the pixel). An axis crossed at `s`, its exit parameter, sits on the
    /// first pixel past the boundary, and `v(s)` lies within rounding of
    /// that boundary: `floor(v(s))` is that pixel, one behind it (kept by
    /// the clamp), or the next one, whose one-pixel exit check (its exit
    /// lies past `s`) takes it back. Only from about `2^23` pixels on could
    /// `v(s)` round two pixels past the boundary; a skipped sync would then
    /// leave the frontier on the pixel past the boundary, which the ray
    /// still crosses.
    #[inline(always)]
    fn sync_in(&self, st: &mut State, c: &Cell) {
        let (x, y) = (self.ax.at(st.s), self.ay.at(st.s));
        let nx = self.ax.sync(st.s, x, st.px, c.ex);
        Self::tie(st, x, nx);
        let ny = self.ay.sync(st.s, y, st.py, c.ey);
        Self::tie(st, y, ny);
        (st.px, st.py) = (nx, ny);
    }

    /// Moves `s` to the crossing parameter `es` (never backward) and counts
    /// the step; returns the new `s`.
    #[inline(always)]
    fn advance(st: &mut State, es: f32) -> f32 {
        st.s = max_nn(st.s, es);
        st.steps += 1;
        st.s
    }

    /// Crosses from cell `c` into its neighbor through the side(s) of exit
    /// parameter `es = min_nn(sx, sy)` (seed 004 Listing 4.5,
    /// `intersectCellBoundary`, with the frontier's integer step in place of
    /// `crossOffset`). `false` when the segment ends inside `c` or the
    /// neighbor lies outside the image.
    ///
    /// The sides crossed are those with `sx <= es` and `sy <= es`. As `sx`
    /// and `sy` are never NaN ([`Axis::exit`]) and `es` is one of them,
    /// that is: `x` alone when `sx < sy`, `y` alone when `sy < sx`, both
    /// when they are equal (a corner), three branches each with only its
    /// own work (one pixel step, one sync of the other axis).
    #[inline(always)]
    fn cross(&self, st: &mut State, c: &Cell, sx: f32, sy: f32, es: f32) -> bool {
        if !(es < 1.0) {
            return false;
        }
        if sx < sy {
            let Some(nx) = self.ax.next(c.ex) else {
                return false;
            };
            let s = Self::advance(st, es);
            if STATS {
                Self::tie(st, self.ax.at(s), nx);
            }
            st.px = nx;
            let y = self.ay.at(s);
            st.py = self.ay.sync(s, y, st.py, c.ey);
            Self::tie(st, y, st.py);
        } else if sy < sx {
            let Some(ny) = self.ay.next(c.ey) else {
                return false;
            };
            let s = Self::advance(st, es);
            let x = self.ax.at(s);
            st.px = self.ax.sync(s, x, st.px, c.ex);
            Self::tie(st, x, st.px);
            if STATS {
                Self::tie(st, self.ay.at(s), ny);
            }
            st.py = ny;
        } else {
            let (Some(nx), Some(ny)) = (self.ax.next(c.ex), self.ay.next(c.ey)) else {
                return false;
            };
            let s = Self::advance(st, es);
            if STATS {
                Self::tie(st, self.ax.at(s), nx);
                Self::tie(st, self.ay.at(s), ny);
            }
            (st.px, st.py) = (nx, ny);
        }
        true
    }

    /// Crosses out of cell `c` (the unit-step resolution's way out).
    #[inline]
    fn leave(&self, st: &mut State, c: &Cell) -> bool {
        let (sx, sy) = (self.ax.exit(c.ex), self.ay.exit(c.ey));
        self.cross(st, c, sx, sy, min_nn(sx, sy))
    }

    /// Visits the cell of level `level` that holds the frontier: one texel
    /// fetch, the exit parameter (the nearer of the two cell sides ahead),
    /// the slab interval up to it, then a hit, a descent or a crossing.
    #[inline(always)]
    fn visit(&self, st: &mut State, level: u32) -> Step {
        self.visit_cell(st, self.cell(st, level))
    }

    /// [`Self::visit`] of level 0 (prologue and unit steps). The cell is the
    /// frontier pixel itself, without the level table and clamps of
    /// [`Self::cell`]: the frontier is always inside the image
    /// (`px <= size - 1`: [`dir_pixel`], [`Axis::sync`] and [`Axis::next`]
    /// keep it there), so `min(px, width - 1) = px`, the edge pixel of a
    /// one-pixel cell is the pixel, and level 0 starts at texel 0.
    #[inline(always)]
    fn visit_pixel(&self, st: &mut State) -> Step {
        let c = Cell {
            level: 0,
            x: st.px,
            y: st.py,
            ex: st.px,
            ey: st.py,
            index: st.py as usize * self.ax.size as usize + st.px as usize,
        };
        self.visit_cell(st, c)
    }

    /// The part of a visit after the cell is known.
    #[inline(always)]
    fn visit_cell(&self, st: &mut State, c: Cell) -> Step {
        let level = c.level;
        // Cells are always inside the pyramid (`HiZ::try_new` checked its
        // length against the layout); ending the walk keeps an impossible
        // index panic-free without materializing a fallback texel.
        let Some(&[zmin, zmax]) = self.data.get(c.index) else {
            return Step::End;
        };
        let (sx, sy) = (self.ax.exit(c.ex), self.ay.exit(c.ey));
        let es = min_nn(sx, sy);
        match self.slab(st, &c, zmin, zmax, min_nn(es, 1.0)) {
            None => {
                if self.cross(st, &c, sx, sy, es) {
                    Step::Next
                } else {
                    Step::End
                }
            }
            Some((sa, _)) if level == 0 => Step::Hit {
                s: sa,
                surface: zmin,
            },
            Some((sa, sb)) => Step::Inside { cell: c, sa, sb },
        }
    }

    /// A level-0 visit for the unit steps (below a `stop_level > 0`),
    /// counted as a fetch. Inlined like every step of the walk: a call out
    /// of line makes the walker's constants live in memory, stored once per
    /// ray whether or not the unit steps run.
    #[inline(always)]
    fn visit0(&self, st: &mut State) -> Step {
        st.fetches += 1;
        self.visit_pixel(st)
    }

    #[inline(always)]
    fn hit(&self, st: State, s: f32, surface: f32) -> Trace {
        let sd = &self.seg;
        let q = sd.q(s);
        let mut t = (sd.t0 + s * sd.k / q).clamp(sd.t0, sd.t1);
        let mut depth = 1.0 / q;
        if NQ {
            // A ray moving away from the camera enters the level-0 slab at
            // its front, `surface` (`slab`: `s = max(st.s, e)`, `e` the
            // entry parameter computed here the same way). Toward the
            // vanishing point the screen parameter cannot resolve depth: a
            // near plane of 7.5e-27 and an infinite far plane put a
            // surface at 39.7 at `s = 1 - 2e-28`, which rounds to 1, where
            // `1 / q` is infinite (fuzz finding F39, F6 of the stepping
            // kernel in Hi-Z). The hit's depth is then the surface's (or,
            // for a ray already inside the slab at `st.s`, no nearer than
            // it), and `t` the ray parameter at that depth.
            let entered = (1.0 / surface - self.q0) / self.dq >= s;
            let off = if entered {
                !((depth - surface).abs() <= RESOLVED_DEPTH * surface)
            } else {
                !(depth >= surface * (1.0 - RESOLVED_DEPTH))
            };
            if off || !(t.is_finite() && depth.is_finite()) {
                // The hit lies on the segment: a surface entered within
                // rounding of the segment's end, past it in exact
                // arithmetic (F14's ray, `t_max` 12), keeps the end and
                // the ray's depth there.
                let tz = (surface - sd.ow) / sd.dw;
                t = tz.clamp(sd.t0, sd.t1);
                depth = if t == tz { surface } else { sd.ow + t * sd.dw };
            }
        }
        let pixel = Vec2::new(
            sd.x(s).clamp(st.px as f32, below(st.px)),
            sd.y(s).clamp(st.py as f32, below(st.py)),
        );
        Trace::Hit(DepthHit {
            pixel,
            t,
            depth,
            surface_depth: surface,
            work: st.work(),
        })
    }

    /// The miss at the end of the segment: passed behind geometry (the end
    /// point lies behind the hit slab of the texel there), left the image,
    /// or simply ended.
    #[inline(always)]
    fn end(&self, mut st: State) -> (Trace, HiZStats) {
        let sd = self.seg;
        let x = dir_pixel(sd.x(1.0), sd.dx, self.ax.size);
        let y = dir_pixel(sd.y(1.0), sd.dy, self.ay.size);
        let index = self.levels[0].offset + y as usize * self.ax.size as usize + x as usize;
        st.fetches += 1;
        let [zmin, zmax] = self.fetch(index);
        let behind = zmin < self.far && sd.q1 < 1.0 / self.upper(&mut st, 0, x, y, zmin, zmax);
        let reason = if behind {
            Miss::BehindGeometry
        } else if sd.ends_on_side {
            Miss::LeftImage
        } else {
            Miss::EndOfRay
        };
        let work = st.work();
        (Trace::Miss { reason, work }, st.stats)
    }

    /// Walks the segment and builds the result: one call site for the hit
    /// and one for the miss at the end, both inlined, so that the walker's
    /// constants stay in registers rather than being stored once per ray
    /// for an out-of-line builder.
    fn run(&self, mut st: State, o: &HiZOptions) -> (Trace, HiZStats) {
        let exit = self.walk_to_exit(&mut st, o);
        self.finish(st, exit)
    }

    /// The result of a walk that ended with `exit` in state `st`.
    #[inline(always)]
    fn finish(&self, st: State, exit: Exit) -> (Trace, HiZStats) {
        match exit {
            Exit::Hit { s, surface } => (self.hit(st, s, surface), st.stats),
            Exit::End => self.end(st),
            Exit::OutOfSteps => {
                let work = st.work();
                let miss = Trace::Miss {
                    reason: Miss::OutOfSteps,
                    work,
                };
                (miss, st.stats)
            }
        }
    }

    /// The prologue and the hierarchical walk, up to a hit, the end of the
    /// segment or the iteration cap.
    #[inline(always)]
    fn walk_to_exit(&self, st: &mut State, o: &HiZOptions) -> Exit {
        let top = self.hiz.layout.count - 1;
        let stop = o.stop_level.min(top);
        let start = o.start_level.min(top).max(stop);
        // Prologue: unit steps (Sec. 4.7.1).
        let mut n = 0;
        while n < o.prologue_steps {
            n += 1;
            st.fetches += 1;
            match self.visit_pixel(st) {
                Step::Hit { s, surface } => return Exit::Hit { s, surface },
                Step::End => return Exit::End,
                Step::Next | Step::Inside { .. } => {}
            }
        }
        // Hierarchical walk (Listings 4.2 / 4.5).
        let mut level = start;
        // For each level, the cell last descended from (its edge pixels)
        // and the end of its possible-hit interval: while the walk stays
        // inside that cell before that end, going back up would only fetch
        // it again. `-inf`: none yet.
        // Three arrays rather than one of triples: a level indexes each
        // with a plain scaled address.
        let mut parent_ex = [0u32; MAX_LEVELS];
        let mut parent_ey = [0u32; MAX_LEVELS];
        let mut parent_sb = [f32::NEG_INFINITY; MAX_LEVELS];
        // Iterations left before the cap, counted down (one decrement and
        // test per iteration); `st.iterations` is set from it on the way out.
        let mut left = o.max_iterations;
        let exit = 'walk: loop {
            if STATS {
                st.stats.max_level = st.stats.max_level.max(level);
            }
            if left == 0 {
                break 'walk Exit::OutOfSteps;
            }
            left -= 1;
            match self.visit(st, level) {
                Step::Hit { s, surface } => break 'walk Exit::Hit { s, surface },
                Step::End => break 'walk Exit::End,
                Step::Next => {
                    if level < top {
                        let up = level + 1;
                        let u = up as usize % MAX_LEVELS;
                        let (ex, ey, sb) = (parent_ex[u], parent_ey[u], parent_sb[u]);
                        if !self.holds(st, ex, ey) || st.s > sb {
                            level = up;
                        }
                    }
                }
                Step::Inside { cell, sa, sb } => {
                    // The frontier moves only if `s` does (`sa > s`): at
                    // the `s` it was last moved to it is already where
                    // `sync_in` would put it (see `Self::sync_in`). With
                    // statistics the sync runs anyway, to count its ties.
                    if STATS || sa > st.s {
                        st.s = sa;
                        self.sync_in(st, &cell);
                    }
                    if level > stop {
                        let l = level as usize % MAX_LEVELS;
                        (parent_ex[l], parent_ey[l], parent_sb[l]) = (cell.ex, cell.ey, sb);
                        level -= 1;
                        continue;
                    }
                    // Unit steps through the cell (Sec. 4.7.1).
                    loop {
                        if !self.holds(st, cell.ex, cell.ey) {
                            break;
                        }
                        if st.s > sb {
                            if !self.leave(st, &cell) {
                                break 'walk Exit::End;
                            }
                            break;
                        }
                        match self.visit0(st) {
                            Step::Hit { s, surface } => break 'walk Exit::Hit { s, surface },
                            Step::End => break 'walk Exit::End,
                            Step::Next => {}
                            Step::Inside { .. } => break,
                        }
                    }
                    level = (level + 1).min(top);
                }
            }
        };
        st.iterations = o.max_iterations - left;
        exit
    }
}

/// How [`Walker::walk_to_exit`] ended.
enum Exit {
    /// Hit at `s` on the surface at linear depth `surface`.
    Hit { s: f32, surface: f32 },
    /// The segment ended (or left the image).
    End,
    /// [`HiZOptions::max_iterations`] reached.
    OutOfSteps,
}

impl<
        'h,
        'a,
        const NX: bool,
        const NY: bool,
        const NQ: bool,
        const BACK: bool,
        const STATS: bool,
    > Walker<'h, 'a, NX, NY, NQ, BACK, STATS>
{
    /// The walker of `seg` (of this class) over `hiz`.
    #[inline(always)]
    fn new(hiz: &'h HiZ<'a>, thickness: Thickness<'a>, seg: Segment) -> Self {
        let (w, h) = (hiz.layout.width, hiz.layout.height);
        Self {
            hiz,
            levels: &hiz.cells,
            data: hiz.data,
            seg,
            ax: Axis::new(seg.x0, seg.dx, w),
            ay: Axis::new(seg.y0, seg.dy, h),
            q0: seg.q0,
            dq: seg.dq,
            thickness,
            th: match thickness {
                Thickness::Constant(th) => th,
                Thickness::BackFaces(_) => 0.0,
            },
            far: hiz.camera.far(),
        }
    }
}

/// Traces a projected segment with the walker of its class ([`Walker`]).
fn walk<const NX: bool, const NY: bool, const NQ: bool, const BACK: bool, const STATS: bool>(
    hiz: &HiZ<'_>,
    thickness: Thickness<'_>,
    seg: Segment,
    options: &HiZOptions,
) -> (Trace, HiZStats) {
    let (w, h) = (hiz.layout.width, hiz.layout.height);
    let walker = Walker::<NX, NY, NQ, BACK, STATS>::new(hiz, thickness, seg);
    let st = State {
        s: 0.0,
        px: dir_pixel(seg.x0, seg.dx, w),
        py: dir_pixel(seg.y0, seg.dy, h),
        steps: 0,
        fetches: 0,
        iterations: 0,
        stats: HiZStats::default(),
    };
    walker.run(st, options)
}

/// The result of a constant-thickness walk of `seg` that ended with `exit`
/// in state `st` (`Walker::finish`), for the AVX2 stream, whose lanes walk
/// and call this per finished ray. The hit and end builders do not depend
/// on the `x` and `y` direction classes, only on `dq`'s sign.
#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
fn finish_lane(
    hiz: &HiZ<'_>,
    thickness: Thickness<'_>,
    seg: Segment,
    st: State,
    exit: Exit,
) -> Trace {
    if seg.dq < 0.0 {
        Walker::<false, false, true, false, false>::new(hiz, thickness, seg)
            .finish(st, exit)
            .0
    } else {
        Walker::<false, false, false, false, false>::new(hiz, thickness, seg)
            .finish(st, exit)
            .0
    }
}

fn trace_valid<const STATS: bool>(
    hiz: &HiZ<'_>,
    thickness: Thickness<'_>,
    ray: &Ray,
    t_max: f32,
    options: &HiZOptions,
) -> (Trace, HiZStats) {
    let Some(seg) = project_segment(hiz, ray, t_max) else {
        return (
            Trace::Miss {
                reason: Miss::DegenerateProjection,
                work: Work::default(),
            },
            HiZStats::default(),
        );
    };
    let back = matches!(thickness, Thickness::BackFaces(_));
    let class = usize::from(seg.dx < 0.0) << 3
        | usize::from(seg.dy < 0.0) << 2
        | usize::from(seg.dq < 0.0) << 1
        | usize::from(back);
    Walks::<STATS>::ALL[class](hiz, thickness, seg, options)
}

/// The [`walk`] of a segment's class.
type WalkFn = fn(&HiZ<'_>, Thickness<'_>, Segment, &HiZOptions) -> (Trace, HiZStats);

/// Every class's [`walk`], one table per statistics setting: one indexed
/// call per ray.
struct Walks<const STATS: bool>;

impl<const STATS: bool> Walks<STATS> {
    /// Indexed by `dx < 0`, `dy < 0`, `dq < 0` and back faces, bits 3 to 0.
    const ALL: [WalkFn; 16] = [
        walk::<false, false, false, false, STATS>,
        walk::<false, false, false, true, STATS>,
        walk::<false, false, true, false, STATS>,
        walk::<false, false, true, true, STATS>,
        walk::<false, true, false, false, STATS>,
        walk::<false, true, false, true, STATS>,
        walk::<false, true, true, false, STATS>,
        walk::<false, true, true, true, STATS>,
        walk::<true, false, false, false, STATS>,
        walk::<true, false, false, true, STATS>,
        walk::<true, false, true, false, STATS>,
        walk::<true, false, true, true, STATS>,
        walk::<true, true, false, false, STATS>,
        walk::<true, true, false, true, STATS>,
        walk::<true, true, true, false, STATS>,
        walk::<true, true, true, true, STATS>,
    ];
}
