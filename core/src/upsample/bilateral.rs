//! Cross-bilateral upsampling of the traced samples to full resolution
//! (seed 004 Sec. 4.7.4; Kopf, Cohen, Lischinski, Uyttendaele, "Joint
//! Bilateral Upsampling", SIGGRAPH 2007), with the depth-edge re-trace
//! list of Sec. 4.7.4.

use super::{try_half_size, Subsample};
use crate::{Error, ImageView, ImageViewMut, MirrorPass, MirrorStatus, MirrorTexel, RowRange};
use glam::{Vec2, Vec3};

/// Settings of the reconstruction ([`UpsamplePass`]).
///
/// # Weights
/// A full-resolution pixel `p` that is not itself traced, with linear
/// depth `z_p` and unit world normal `n_p` (the G-buffer's), takes the
/// samples of the blocks around it (those of the two block columns and
/// rows nearest to it: no other lies within the spatial kernel's reach of
/// one pixel). Sample `k`, traced
/// at full-resolution pixel `s_k` with the G-buffer's `z_k`, `n_k` there,
/// weighs
///
/// `w_k = S(p - s_k) D(r_k) N(n_k . n_p)`,
///
/// Kopf et al. 2007 Eq. 2, `S~_p = 1/k_p sum_q S_q f(|p - q|) g(|I_p -
/// I_q|)` with `k_p = sum_q f g`, whose guide `I` here is the depth and
/// the normal of the full-resolution G-buffer, read at the pixel the
/// sample was traced at (exact: no downsampled guide is needed):
///
/// * spatial `S(d) = max(0, 1 - |d.x| / 2) max(0, 1 - |d.y| / 2)`, in
///   full-resolution pixels: the bilinear (tent) kernel of samples two
///   pixels apart, Kopf's `f` (the seed's Sec. 4.7.3 "signal
///   reconstruction filter"). On the uniform grid a pixel between two
///   samples weighs them `1/2` each, one in the middle of four `1/4` each.
/// * depth `D(r) = exp(-r^2 / (2 depth_sigma^2))` for `r = |z_k - z'| /
///   z_p <= depth_threshold`, and `0` for larger `r` (or NaN): Kopf's
///   Gaussian range kernel `g` on the relative depth difference, cut at
///   the depth edge so that no sample across an edge larger than
///   [`UpsampleOptions::depth_threshold`] contributes at all (Sec. 4.7.4,
///   "preserving silhouettes and hard edges"). `z'` is the depth the
///   sample is compared with: the pixel's own depth `z_p` (Kopf's guide
///   difference, the default), or with [`UpsampleOptions::plane_depth`]
///   the linear depth of `p`'s tangent plane on the view ray of the
///   sample's pixel, `z' = z_p (n . a_p) / (n . a_k)` for the view-space
///   normal `n` and the pixel rays `a = (ndc_x tan_x, ndc_y tan_y, -1)`
///   of `p` and `s_k` (a sample whose ray meets that plane behind the eye
///   or not at all contributes nothing). A surface's depth changes along
///   it: a floor seen at a grazing angle can change by more than the
///   threshold from one pixel to the next (22% from floor pixel (9, 13)
///   of this module's 16 x 16 example to its sample one row above), so
///   the own depth cuts such floors into pixels to re-trace where the
///   plane's depth does not; on a surface facing the camera both are
///   `z_p`. Measured on the room (`refl report --quick --method hiz`,
///   256 x 192, where a pixel's own floor changes by a few percent), the
///   own depth gave the lower error (5.23 against 5.72 on the 0..255
///   scale, full resolution 3.96): a tangent plane seen edge-on (at a
///   curved object's silhouette) predicts any depth and lets the
///   background in, and the Gaussian of the own depth breaks the ties
///   between a hit and a miss on either side of a depth change in favor
///   of the nearer surface (without it, 5.73: more pixels take a hit the
///   full pass does not find). Its price is a tilt on depth gradients: on
///   the mirror floor of `core/tests/upsample.rs` the reconstructed hit
///   is off the exact one by 0.02 px (median) to 0.26 px (99th
///   percentile) for the pixel's own depth, 0.005 px along the plane.
/// * normal `N(c) = max(0, c)^normal_power` (`1` for a power of `0`): a
///   second range term on the G-buffer's normals, beyond the seed and
///   Kopf et al. (whose guide is one image), as production upsamplers
///   weigh normals: a crease at equal depth is an edge the depth cannot
///   see, and a mirror's reflection turns with its normal.
///
/// The samples are split by answer (a hit; the sky; a ray for the host);
/// the class with the largest weight sum (ties: hit, sky, host) gives the
/// pixel its status, and its color is the normalized weighted mean `sum
/// w_k c_k / sum w_k` of that class's samples only (a reflection color is
/// never mixed with a miss's black or the host's fallback). A hit's
/// position, distance `t` and confidence are the same weighted means of
/// its hits, and with [`UpsampleOptions::shade_hits`] its color is the lit
/// color at that position; a host class takes the status of its heaviest
/// sample (the first of equal weights in row-major block order).
///
/// A sample contributes only with a usable surface at its pixel (the
/// G-buffer's [`crate::GBuffer::surface`] depth range and normal), a
/// status that answers or goes to the host (not
/// [`MirrorStatus::Skipped`] or [`MirrorStatus::NoSurface`]), a finite
/// color and, for a hit, finite hit fields; and with `w_k > 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpsampleOptions {
    /// The depth edge: samples whose linear depth differs from the
    /// compared depth `z'` (the pixel's own, or its tangent plane's) by
    /// more than this fraction of the pixel's depth get weight `0` (`> 0`,
    /// not NaN; `+inf` turns the edge off). Default 0.1.
    pub depth_threshold: f32,
    /// Width of the Gaussian depth weight, as a fraction of the pixel's
    /// depth (`> 0`, not NaN; `+inf`: every sample within the threshold
    /// weighs the same). Default 0.05.
    pub depth_sigma: f32,
    /// Exponent of the normal weight (finite, `>= 0`; `0` turns it off).
    /// Default 8 (a cosine of 0.9, 26 degrees, weighs 0.43).
    pub normal_power: f32,
    /// Compare a sample's depth with the depth of the pixel's tangent
    /// plane at the sample's pixel rather than with the pixel's own depth
    /// ("Weights" above): for floors seen at grazing angles at low
    /// resolution. Default `false`.
    pub plane_depth: bool,
    /// A reconstructed hit takes the G-buffer's lit color at its
    /// interpolated hit position, as the mirror pass shades a hit
    /// ([`MirrorPass::shade`]), rather than the weighted mean of its
    /// samples' colors: where the hit position varies smoothly (a planar
    /// mirror) this keeps the reflected image at full resolution. Used
    /// only with a color input and a G-buffer color. Default `true`.
    pub shade_hits: bool,
    /// Pixels no sample reaches are traced at full resolution by the
    /// mirror pass ([`UpsampleStatus::Retraced`]) instead of listed
    /// ([`UpsampleStatus::Retrace`]). Default `false`.
    pub retrace: bool,
    /// Pixels whose samples answer differently (a hit and a miss, a hit
    /// and the sky: a reflected silhouette) are treated as reached by no
    /// sample: listed or re-traced. Default `false`.
    pub retrace_mixed: bool,
}

impl Default for UpsampleOptions {
    fn default() -> Self {
        Self {
            depth_threshold: 0.1,
            depth_sigma: 0.05,
            normal_power: 8.0,
            plane_depth: false,
            shade_hits: true,
            retrace: false,
            retrace_mixed: false,
        }
    }
}

impl UpsampleOptions {
    /// # Errors
    /// [`Error::InvalidArgument`] if a field is NaN or outside its range.
    pub fn try_validate(&self) -> Result<(), Error> {
        let ok = self.depth_threshold > 0.0
            && self.depth_sigma > 0.0
            && self.normal_power >= 0.0
            && self.normal_power.is_finite();
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidArgument)
        }
    }
}

/// How a full-resolution pixel was made (per pixel of
/// [`UpsamplePass::try_run`]'s status image, as a byte).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum UpsampleStatus {
    /// No reflection: the pixel is not reflective or has no surface (its
    /// texel says which, as the full pass would).
    #[default]
    Skipped = 0,
    /// The pixel is its block's traced pixel: the sample itself, exactly.
    Copied = 1,
    /// Reconstructed from the samples around it (Sec. 4.7.4).
    Interpolated = 2,
    /// No sample reaches it (across a depth edge, a crease, no neighbor
    /// with a surface; or mixed answers with
    /// [`UpsampleOptions::retrace_mixed`]): it needs a full-resolution
    /// trace, and is listed. Its texel is the default (no answer) and its
    /// color black.
    Retrace = 3,
    /// As [`UpsampleStatus::Retrace`], traced at full resolution by the
    /// pass ([`UpsampleOptions::retrace`]): what the full pass gives there.
    Retraced = 4,
}

impl UpsampleStatus {
    /// The pixel's texel is a trace of the pixel itself
    /// ([`UpsampleStatus::Copied`], [`UpsampleStatus::Retraced`]).
    pub const fn is_traced(self) -> bool {
        matches!(self, Self::Copied | Self::Retraced)
    }

    /// What the temporal filter's `answered` image should hold for a
    /// pixel of this status and texel status (module docs of
    /// [`crate::upsample`], "Temporal super-sampling"): traced this frame
    /// and answered ([`MirrorStatus::Hit`] or [`MirrorStatus::Sky`]).
    pub const fn answers(self, texel: MirrorStatus) -> bool {
        self.is_traced() && matches!(texel, MirrorStatus::Hit | MirrorStatus::Sky)
    }
}

/// Counts of one run over a band.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UpsampleStats {
    /// Traced pixels copied ([`UpsampleStatus::Copied`]).
    pub copied: u32,
    /// Reconstructed pixels ([`UpsampleStatus::Interpolated`]).
    pub interpolated: u32,
    /// Pixels no sample reached ([`UpsampleStatus::Retrace`] and
    /// [`UpsampleStatus::Retraced`]).
    pub retrace: u32,
    /// Of the listed ones, those stored in the list (the rest did not
    /// fit).
    pub retrace_written: u32,
    /// Of those, the ones traced at full resolution
    /// ([`UpsampleOptions::retrace`]).
    pub retraced: u32,
    /// Pixels whose texel is a [`MirrorStatus::Hit`].
    pub hits: u32,
}

/// Where [`UpsamplePass::try_run_rows`] puts its results.
pub trait UpsampleSink {
    /// Pixel `(x, y)`'s texel, color (black without a color input) and
    /// status.
    fn texel(
        &mut self,
        x: u32,
        y: u32,
        texel: &MirrorTexel,
        color: [f32; 3],
        status: UpsampleStatus,
    );
    /// Re-trace entry number `index` of this run (0, 1, ... in row-major
    /// order, counting only those stored): pixel `(x, y)`. Returns `false`
    /// if it was not stored (the list is full).
    fn retrace(&mut self, index: u32, x: u32, y: u32) -> bool;
}

/// The reconstruction of one frame's traced samples at full resolution
/// (module docs of [`crate::upsample`]; the weights on
/// [`UpsampleOptions`]).
#[derive(Clone, Copy, Debug)]
pub struct UpsamplePass<'a> {
    pass: MirrorPass<'a>,
    subsample: Subsample,
    texels: ImageView<'a, MirrorTexel>,
    color: Option<ImageView<'a, [f32; 3]>>,
    options: UpsampleOptions,
    /// The G-buffer's size.
    size: (u32, u32),
    /// [`UpsampleOptions::normal_power`] when it is a whole number up to
    /// 64 (raised by squaring).
    whole_power: Option<u32>,
    /// How a view-space pixel ray `a` changes per pixel in `x` and `y`.
    ray_step: Vec2,
}

/// The answer classes of the samples (ties resolved in this order).
const HIT: usize = 0;
const SKY: usize = 1;
const HOST: usize = 2;

/// One contributing sample.
#[derive(Clone, Copy, Debug, Default)]
struct Sample {
    weight: f32,
    class: usize,
    texel: MirrorTexel,
    color: Vec3,
}

/// The weighted sums of one answer class's samples.
#[derive(Clone, Copy, Debug)]
struct Class {
    weight: f32,
    color: Vec3,
    pixel: Vec2,
    t: f32,
    confidence: f32,
    /// The heaviest sample's weight, texel and color (the first of equal
    /// weights).
    heaviest: f32,
    heaviest_texel: MirrorTexel,
    heaviest_color: Vec3,
}

impl Default for Class {
    fn default() -> Self {
        Self {
            weight: 0.0,
            color: Vec3::ZERO,
            pixel: Vec2::ZERO,
            t: 0.0,
            confidence: 0.0,
            heaviest: 0.0,
            heaviest_texel: MirrorTexel::default(),
            heaviest_color: Vec3::ZERO,
        }
    }
}

impl Class {
    fn add(&mut self, s: &Sample) {
        let w = s.weight;
        self.weight += w;
        self.color += s.color * w;
        self.pixel += s.texel.pixel * w;
        self.t += s.texel.t * w;
        self.confidence += s.texel.confidence * w;
        if w > self.heaviest {
            self.heaviest = w;
            self.heaviest_texel = s.texel;
            self.heaviest_color = s.color;
        }
    }
}

/// What a pixel's samples are compared with: its pixel, linear depth,
/// unit world normal and, with [`UpsampleOptions::plane_depth`], its
/// view-space normal `n`, `n . a_p` and `z_p (n . a_p)` (the tangent
/// plane's depth on a pixel ray `a` is the last over `n . a`).
struct Guide {
    x: u32,
    y: u32,
    depth: f32,
    normal: Vec3,
    plane: Option<(Vec3, f32, f32)>,
}

/// `c^e` by squaring.
#[inline]
fn powi(c: f32, e: u32) -> f32 {
    let (mut base, mut e, mut out) = (c, e, 1.0f32);
    while e > 0 {
        if e & 1 == 1 {
            out *= base;
        }
        base *= base;
        e >>= 1;
    }
    out
}

/// Kopf et al. 2007 Eq. 2's range weight `g` on the relative depth
/// difference `r` ([`UpsampleOptions`], "Weights"):
/// `exp(-r^2 / (2 sigma^2))` (`1` for an infinite `sigma`), `None` past
/// the depth edge `threshold` or for a NaN `r`.
#[inline]
pub(crate) fn depth_weight(r: f32, threshold: f32, sigma: f32) -> Option<f32> {
    if !(r <= threshold) {
        return None;
    }
    Some(if sigma.is_finite() {
        let q = r / sigma;
        libm::expf(-0.5 * q * q)
    } else {
        1.0
    })
}

/// The normal range weight `max(0, c)^power` of a normal cosine `c`
/// (`1` for a power of `0`; [`UpsampleOptions`], "Weights"), raised by
/// squaring when `whole` holds the power as a whole number
/// ([`whole_power`]).
#[inline]
pub(crate) fn normal_weight(c: f32, power: f32, whole: Option<u32>) -> f32 {
    if power > 0.0 {
        if c > 0.0 {
            let c = c.min(1.0);
            match whole {
                Some(e) => powi(c, e),
                None => libm::powf(c, power),
            }
        } else {
            0.0
        }
    } else {
        1.0
    }
}

/// `power` as a whole number up to 64, when it is one (for
/// [`normal_weight`]).
pub(crate) fn whole_power(power: f32) -> Option<u32> {
    (power <= 64.0 && power == libm::truncf(power)).then_some(power as u32)
}

/// The bilinear (tent) weight of a sample `d` full-resolution pixels away
/// along one axis (Kopf et al. 2007 Eq. 2's spatial `f`, [`UpsampleOptions`]).
#[inline]
fn tent(d: u32) -> f32 {
    match d {
        0 => 1.0,
        1 => 0.5,
        _ => 0.0,
    }
}

impl<'a> UpsamplePass<'a> {
    /// Binds the pass that traced the samples (its G-buffer is the
    /// full-resolution guide; [`UpsampleOptions::retrace`] traces with
    /// it), the [`Subsample`] they were traced with, the half-resolution
    /// texels and, optionally, their colors ([`super::HalfPass`]'s outputs,
    /// or the host's: a color image may hold the host's answers of the
    /// sky and host samples too) and the options.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `texels` or `color` is not the half
    /// size of the pass's G-buffer ([`super::try_half_size`]), or an
    /// option is out of range ([`UpsampleOptions::try_validate`]).
    pub fn try_new(
        pass: MirrorPass<'a>,
        subsample: Subsample,
        texels: ImageView<'a, MirrorTexel>,
        color: Option<ImageView<'a, [f32; 3]>>,
        options: UpsampleOptions,
    ) -> Result<Self, Error> {
        options.try_validate()?;
        let g = pass.gbuffer();
        let (w, h) = try_half_size(g.width(), g.height())?;
        if texels.width() != w
            || texels.height() != h
            || color.is_some_and(|c| c.width() != w || c.height() != h)
        {
            return Err(Error::InvalidArgument);
        }
        let whole_power = whole_power(options.normal_power);
        let cam = g.camera();
        let a = cam.view_dir_through(Vec2::new(0.5, 0.5));
        let b = cam.view_dir_through(Vec2::new(1.5, 1.5));
        Ok(Self {
            pass,
            subsample,
            texels,
            color,
            options,
            size: (g.width(), g.height()),
            whole_power,
            ray_step: Vec2::new(b.x - a.x, b.y - a.y),
        })
    }

    /// The options.
    pub const fn options(&self) -> &UpsampleOptions {
        &self.options
    }

    /// The pixels the samples were traced at.
    pub const fn subsample(&self) -> Subsample {
        self.subsample
    }

    /// The pass that traced them.
    pub const fn pass(&self) -> &MirrorPass<'a> {
        &self.pass
    }

    /// Pixel `(x, y)`'s texel, color and status, as
    /// [`UpsamplePass::try_run`] writes them (re-tracing included);
    /// `(default, black, Skipped)` outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> (MirrorTexel, [f32; 3], UpsampleStatus) {
        if x >= self.size.0 || y >= self.size.1 {
            return (MirrorTexel::default(), [0.0; 3], UpsampleStatus::Skipped);
        }
        self.resolve(x, y)
    }

    /// The full-resolution pixel block `(bx, by)` (inside the half
    /// image) traced: [`Subsample::traced_pixel`].
    #[inline]
    fn traced(&self, bx: u32, by: u32) -> (u32, u32) {
        let s = self.subsample.sub_pixel(bx, by);
        (
            (2 * bx + s.x).min(self.size.0 - 1),
            (2 * by + s.y).min(self.size.1 - 1),
        )
    }

    /// Sample `(bx, by)` with its weight for the pixel of `guide`
    /// ([`UpsampleOptions`], "Weights"), if it contributes.
    fn sample(&self, bx: u32, by: u32, guide: &Guide) -> Option<Sample> {
        let g = self.pass.gbuffer();
        let (sx, sy) = self.traced(bx, by);
        let spatial = tent(sx.abs_diff(guide.x)) * tent(sy.abs_diff(guide.y));
        if !(spatial > 0.0) {
            return None;
        }
        let texel = self.texels.get(bx, by)?;
        let class = match texel.status {
            MirrorStatus::Hit => HIT,
            MirrorStatus::Sky => SKY,
            s if s.needs_host() => HOST,
            _ => return None,
        };
        let color = Vec3::from_array(match &self.color {
            Some(c) => c.get(bx, by)?,
            None => [0.0; 3],
        });
        if !color.is_finite() {
            return None;
        }
        if class == HIT
            && !(texel.pixel.is_finite() && texel.t.is_finite() && texel.confidence.is_finite())
        {
            return None;
        }
        // The guide at the sample's pixel: a usable surface.
        let cam = g.camera();
        let zk = g.depth().linear_at(sx, sy)?;
        if !(zk >= cam.near() && zk < cam.far()) {
            return None;
        }
        let nk = g.world_normal(sx, sy)?;
        // Depth: the hard edge, then the Gaussian range weight.
        let z = guide.depth;
        let compared = match guide.plane {
            // z' = z_p (n . a_p) / (n . a_k), with a_k = a_p + the ray's
            // change over the pixels between them.
            Some((nv, na, k)) => {
                let dx = sx as f32 - guide.x as f32;
                let dy = sy as f32 - guide.y as f32;
                let nak = na + dx * self.ray_step.x * nv.x + dy * self.ray_step.y * nv.y;
                let zp = k / nak;
                if !(zp > 0.0 && zp.is_finite()) {
                    return None;
                }
                zp
            }
            None => z,
        };
        let r = (zk - compared).abs() / z;
        let o = &self.options;
        let depth = depth_weight(r, o.depth_threshold, o.depth_sigma)?;
        let normal = normal_weight(nk.dot(guide.normal), o.normal_power, self.whole_power);
        let weight = spatial * depth * normal;
        (weight > 0.0).then_some(Sample {
            weight,
            class,
            texel,
            color,
        })
    }

    /// The pixel's result when no sample reaches it.
    fn unreached(&self, x: u32, y: u32) -> (MirrorTexel, [f32; 3], UpsampleStatus) {
        if self.options.retrace {
            let (t, _) = self.pass.pixel(x, y);
            let c = if self.color.is_some() {
                self.pass.shade(&t)
            } else {
                [0.0; 3]
            };
            (t, c, UpsampleStatus::Retraced)
        } else {
            (MirrorTexel::default(), [0.0; 3], UpsampleStatus::Retrace)
        }
    }

    /// The pixel's surface as the mirror pass sees it: its linear depth
    /// and stored unit world normal, or the status the pass gives a pixel
    /// it does not trace ([`MirrorStatus::Skipped`]: not reflective;
    /// [`MirrorStatus::NoSurface`]: no [`crate::GBuffer::surface`], or a
    /// surface point at the eye, where the pass has no reflection ray).
    fn surface(&self, x: u32, y: u32) -> Result<(f32, Vec3), MirrorStatus> {
        if !self.pass.reflective(x, y) {
            return Err(MirrorStatus::Skipped);
        }
        let g = self.pass.gbuffer();
        let s = g.surface(x, y).ok_or(MirrorStatus::NoSurface)?;
        // The pass's ray generation fails exactly where the view vector
        // `P - eye` is zero or not finite (it scales finite non-zero
        // vectors before normalizing them, and the mirror of a unit vector
        // about a unit normal has unit length).
        let v = s.position - g.camera().eye();
        if v == Vec3::ZERO || !v.is_finite() {
            return Err(MirrorStatus::NoSurface);
        }
        Ok((s.depth, s.normal))
    }

    fn resolve(&self, x: u32, y: u32) -> (MirrorTexel, [f32; 3], UpsampleStatus) {
        let (bx, by) = (x / 2, y / 2);
        // A traced pixel: its own result, whatever it is.
        if self.traced(bx, by) == (x, y) {
            let t = self.texels.get(bx, by).unwrap_or_default();
            if matches!(t.status, MirrorStatus::Skipped | MirrorStatus::NoSurface) {
                return (t, [0.0; 3], UpsampleStatus::Skipped);
            }
            let c = self
                .color
                .as_ref()
                .and_then(|c| c.get(bx, by))
                .unwrap_or([0.0; 3]);
            return (t, c, UpsampleStatus::Copied);
        }
        let (z, n) = match self.surface(x, y) {
            Ok(s) => s,
            Err(status) => {
                let t = MirrorTexel {
                    status,
                    ..MirrorTexel::default()
                };
                return (t, [0.0; 3], UpsampleStatus::Skipped);
            }
        };
        let g = self.pass.gbuffer();
        let cam = g.camera();
        let plane = self.options.plane_depth.then(|| {
            let nv = cam.view().transform_vector3(n);
            let a = cam.view_dir_through(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let na = nv.dot(a);
            (nv, na, z * na)
        });
        let guide = Guide {
            x,
            y,
            depth: z,
            normal: n,
            plane,
        };
        let mut acc = [Class::default(); 3];
        // A block's sample lies in its own two columns and rows, so only
        // the blocks of the two columns and rows nearest the pixel can be
        // within the tent's reach (one pixel): those left and right of an
        // odd column's pixel, the pixel's own and the one before it for
        // an even column; rows alike.
        let (hw, hh) = (self.texels.width(), self.texels.height());
        let x0 = bx + (x & 1);
        let y0 = by + (y & 1);
        for cy in y0.saturating_sub(1)..(y0 + 1).min(hh) {
            for cx in x0.saturating_sub(1)..(x0 + 1).min(hw) {
                if let Some(s) = self.sample(cx, cy, &guide) {
                    acc[s.class].add(&s);
                }
            }
        }
        let classes = acc.iter().filter(|a| a.weight > 0.0).count();
        if classes == 0 || (classes > 1 && self.options.retrace_mixed) {
            return self.unreached(x, y);
        }
        // The heaviest class (ties: hit, sky, host).
        let mut class = HIT;
        for c in [SKY, HOST] {
            if acc[c].weight > acc[class].weight {
                class = c;
            }
        }
        let a = &acc[class];
        let inv = 1.0 / a.weight;
        let mut color = a.color * inv;
        // A sum of colors near f32::MAX may overflow: the heaviest's.
        if !color.is_finite() {
            color = a.heaviest_color;
        }
        let texel = match class {
            HIT => {
                let t = MirrorTexel {
                    status: MirrorStatus::Hit,
                    pixel: a.pixel * inv,
                    t: a.t * inv,
                    confidence: (a.confidence * inv).clamp(0.0, 1.0),
                };
                if !(t.pixel.is_finite() && t.t.is_finite()) {
                    return self.unreached(x, y);
                }
                if self.options.shade_hits && self.color.is_some() && g.color().is_some() {
                    color = Vec3::from_array(self.pass.shade(&t));
                }
                t
            }
            SKY => MirrorTexel {
                status: MirrorStatus::Sky,
                ..MirrorTexel::default()
            },
            _ => MirrorTexel {
                status: a.heaviest_texel.status,
                ..MirrorTexel::default()
            },
        };
        (texel, color.to_array(), UpsampleStatus::Interpolated)
    }

    /// Runs the reconstruction over the rows `out` owns (a whole
    /// full-resolution image or a band from [`ImageViewMut::try_band`]):
    /// writes every pixel's [`MirrorTexel`] (a hit's `pixel`, `t` and
    /// `confidence` interpolated as [`UpsampleOptions`] says), its color
    /// into `color` (needs a color input), its [`UpsampleStatus`] as a
    /// byte into `status`, and appends the pixels that need a
    /// full-resolution trace (as `[x, y]`, row-major) to `retrace` as far
    /// as it holds them (with [`UpsampleOptions::retrace`] they are traced
    /// instead and nothing is listed). Host rays are not listed: a pixel's
    /// texel status says whether it needs the host
    /// ([`MirrorStatus::needs_host`]) and [`MirrorPass::host_ray`] gives
    /// its full-resolution ray. Two bands give what one call over both
    /// gives (the list restarts at each call).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `out`, `color` or `status` is not the
    /// G-buffer's size, or their bands differ, or `color` is given without
    /// a color input. Nothing is written then.
    ///
    /// # Example
    /// See the module docs of [`crate::upsample`].
    pub fn try_run(
        &self,
        out: &mut ImageViewMut<'_, MirrorTexel>,
        color: Option<&mut ImageViewMut<'_, [f32; 3]>>,
        status: Option<&mut ImageViewMut<'_, u8>>,
        retrace: &mut [[u32; 2]],
    ) -> Result<UpsampleStats, Error> {
        let g = self.pass.gbuffer();
        let (w, h) = (g.width(), g.height());
        if color.is_some() && self.color.is_none() {
            return Err(Error::InvalidArgument);
        }
        if out.width() != w || out.height() != h {
            return Err(Error::InvalidArgument);
        }
        let rows = out.owned_rows();
        let same = |vw: u32, vh: u32, vr: Option<RowRange>| vw == w && vh == h && vr == rows;
        if color
            .as_deref()
            .is_some_and(|c| !same(c.width(), c.height(), c.owned_rows()))
            || status
                .as_deref()
                .is_some_and(|s| !same(s.width(), s.height(), s.owned_rows()))
        {
            return Err(Error::InvalidArgument);
        }
        let Some(rows) = rows else {
            return Ok(UpsampleStats::default());
        };
        let mut sink = ImagesSink {
            out,
            color,
            status,
            retrace,
        };
        Ok(self.run_rows(rows, &mut sink))
    }

    /// Runs the reconstruction over `rows` (checked against the
    /// G-buffer's height) and hands every pixel's texel, color and status,
    /// and every re-trace entry, to `sink`: the loop of
    /// [`UpsamplePass::try_run`] for hosts whose buffers are not
    /// [`ImageViewMut`]s.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `rows` ends beyond the G-buffer's
    /// height. Nothing is handed to `sink` then.
    pub fn try_run_rows(
        &self,
        rows: RowRange,
        sink: &mut impl UpsampleSink,
    ) -> Result<UpsampleStats, Error> {
        if rows.end() > self.pass.gbuffer().height() {
            return Err(Error::InvalidArgument);
        }
        Ok(self.run_rows(rows, sink))
    }

    fn run_rows(&self, rows: RowRange, sink: &mut impl UpsampleSink) -> UpsampleStats {
        let mut stats = UpsampleStats::default();
        for y in rows.rows() {
            for x in 0..self.size.0 {
                let (t, c, s) = self.resolve(x, y);
                match s {
                    UpsampleStatus::Skipped => {}
                    UpsampleStatus::Copied => stats.copied += 1,
                    UpsampleStatus::Interpolated => stats.interpolated += 1,
                    UpsampleStatus::Retrace => {
                        stats.retrace += 1;
                        if sink.retrace(stats.retrace_written, x, y) {
                            stats.retrace_written += 1;
                        }
                    }
                    UpsampleStatus::Retraced => {
                        stats.retrace += 1;
                        stats.retraced += 1;
                    }
                }
                if t.status == MirrorStatus::Hit {
                    stats.hits += 1;
                }
                sink.texel(x, y, &t, c, s);
            }
        }
        stats
    }
}

/// The image outputs of [`UpsamplePass::try_run`].
struct ImagesSink<'o, 'c, 's, 'r, 'x, 'y, 'z> {
    out: &'o mut ImageViewMut<'x, MirrorTexel>,
    color: Option<&'c mut ImageViewMut<'y, [f32; 3]>>,
    status: Option<&'s mut ImageViewMut<'z, u8>>,
    retrace: &'r mut [[u32; 2]],
}

impl UpsampleSink for ImagesSink<'_, '_, '_, '_, '_, '_, '_> {
    fn texel(
        &mut self,
        x: u32,
        y: u32,
        texel: &MirrorTexel,
        color: [f32; 3],
        status: UpsampleStatus,
    ) {
        if let Some(p) = self.out.get_mut(x, y) {
            *p = *texel;
        }
        if let Some(p) = self.color.as_deref_mut().and_then(|c| c.get_mut(x, y)) {
            *p = color;
        }
        if let Some(p) = self.status.as_deref_mut().and_then(|s| s.get_mut(x, y)) {
            *p = status as u8;
        }
    }

    fn retrace(&mut self, index: u32, x: u32, y: u32) -> bool {
        match self.retrace.get_mut(index as usize) {
            Some(slot) => {
                *slot = [x, y];
                true
            }
            None => false,
        }
    }
}
