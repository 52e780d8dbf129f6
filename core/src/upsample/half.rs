//! The mirror pass on one pixel of every 2x2 block (seed 004 Sec. 4.7.3,
//! 4.7.4), written into a half-resolution image.

use super::{try_half_size, Subsample};
use crate::ssr::ImageSink;
use crate::{
    Error, HostRay, ImageViewMut, MirrorPass, MirrorSink, MirrorStats, MirrorTexel, RowRange,
};

/// The mirror pass traced on the pixels a [`Subsample`] picks, one per
/// 2x2 block, into half-resolution images (module docs of
/// [`crate::upsample`]).
///
/// Texel `(bx, by)` of the output is the result of full-resolution pixel
/// [`Subsample::traced_pixel`]`(bx, by, ..)`: exactly the
/// [`MirrorTexel`] and color [`MirrorPass::try_run`] writes there (the
/// same ray, start, kernel and validation; hit positions stay in
/// full-resolution pixels). Host rays carry their full-resolution pixel.
#[derive(Clone, Copy, Debug)]
pub struct HalfPass<'a> {
    pass: MirrorPass<'a>,
    subsample: Subsample,
    size: (u32, u32),
}

impl<'a> HalfPass<'a> {
    /// The pass `pass` on the pixels `subsample` picks.
    pub fn new(pass: MirrorPass<'a>, subsample: Subsample) -> Self {
        let g = pass.gbuffer();
        // A G-buffer is never empty (its image views refuse zero sizes).
        let size = try_half_size(g.width(), g.height()).unwrap_or((0, 0));
        Self {
            pass,
            subsample,
            size,
        }
    }

    /// The full-resolution pass.
    pub const fn pass(&self) -> &MirrorPass<'a> {
        &self.pass
    }

    /// The pixels it traces.
    pub const fn subsample(&self) -> Subsample {
        self.subsample
    }

    /// Width and height of its output images ([`super::try_half_size`] of
    /// the G-buffer).
    pub const fn size(&self) -> (u32, u32) {
        self.size
    }

    /// The full-resolution pixel of output texel `(bx, by)`, `None`
    /// outside the output.
    pub const fn traced_pixel(&self, bx: u32, by: u32) -> Option<(u32, u32)> {
        let g = self.pass.gbuffer();
        self.subsample.traced_pixel(bx, by, g.width(), g.height())
    }

    /// Traces the traced pixels of the output rows `out` owns (a whole
    /// half-resolution image or a band of it): writes each block's
    /// [`MirrorTexel`], its color into `color` (the lit color at a hit,
    /// black elsewhere; needs a G-buffer color) and appends the pixels
    /// that need the host's tracer to `host` (full-resolution pixels, in
    /// block row-major order), as far as `host` holds them. Two bands give
    /// what one call over both gives (host lists restart at each call).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `out` or `color` is not [`Self::size`]
    /// or their bands differ, or `color` is given without a G-buffer color.
    /// Nothing is written then.
    ///
    /// # Example
    /// See the module docs of [`crate::upsample`].
    pub fn try_run(
        &self,
        out: &mut ImageViewMut<'_, MirrorTexel>,
        color: Option<&mut ImageViewMut<'_, [f32; 3]>>,
        host: &mut [HostRay],
    ) -> Result<MirrorStats, Error> {
        if color.is_some() && self.pass.gbuffer().color().is_none() {
            return Err(Error::InvalidArgument);
        }
        let (w, h) = self.size;
        match ImageSink::try_new(out, color, host, w, h)? {
            Some((rows, mut sink)) => Ok(self.run_rows(rows, &mut sink)),
            None => Ok(MirrorStats::default()),
        }
    }

    /// Traces the blocks of the output rows `rows` (checked against
    /// [`Self::size`]) and hands every block's texel and color (at the
    /// block's coordinates) and every host ray (full-resolution pixel) to
    /// `sink`: the loop of [`HalfPass::try_run`] for hosts whose buffers
    /// are not [`ImageViewMut`]s.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `rows` ends beyond the output's
    /// height. Nothing is handed to `sink` then.
    pub fn try_run_rows(
        &self,
        rows: RowRange,
        sink: &mut impl MirrorSink,
    ) -> Result<MirrorStats, Error> {
        if rows.end() > self.size.1 {
            return Err(Error::InvalidArgument);
        }
        Ok(self.run_rows(rows, sink))
    }

    fn run_rows(&self, rows: RowRange, sink: &mut impl MirrorSink) -> MirrorStats {
        let mut stats = MirrorStats::default();
        for by in rows.rows() {
            for bx in 0..self.size.0 {
                let Some((x, y)) = self.traced_pixel(bx, by) else {
                    continue;
                };
                let (t, rgb) = self.pass.run_pixel(x, y, &mut stats, sink);
                sink.texel(bx, by, &t, rgb);
            }
        }
        stats
    }
}
