//! The planar mirror pass (`refl_core::planar`): one call sets up the
//! mirrored render (camera, oblique projection, clip plane, winding, the
//! covered pixels and their scissor), one call per row band resolves the
//! reflection from the host's render.
//!
//! A frame: `refl_planar_options_default` (or your own options),
//! `refl_planar_prepare` (skip the mirrored render when `covered` is
//! false), render the scene through `setup.camera` with
//! `setup.projection`, then `refl_planar_resolve_rows` once per band from
//! any number of threads. `refl_planar_cover_rows` writes the coverage
//! alone (a stencil for compositing, or the scissor computed over bands).

use crate::gbuffer::{gbuffer, gbuffer_ranges, put_host_ray, refl_gbuffer, refl_host_ray};
use crate::image::{
    refl_image_f32, refl_image_u32, refl_image_vec3, refl_image_vec3_mut, refl_row_range,
};
use crate::ptr::{byte_len, check_buffer, disjoint, read, Out};
use crate::status::{fail, guard, refl_status};
use crate::types::{refl_camera, refl_mat4, refl_plane, refl_vec2, refl_vec4};
use refl_core::{
    Error, PlanarOptions, PlanarPass, PlanarRay, PlanarRect, PlanarRender, PlanarSink, PlanarStats,
    PlanarStatus, PlanarTexel, Plane, RowRange,
};

/// Settings of the planar pass; `refl_planar_options_default` gives the
/// defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_planar_options {
    /// Resolution divisor of the mirrored render, >= 1: it has
    /// ceil(width / scale) x ceil(height / scale) pixels. Default 1.
    pub scale: u32,
    /// Clip at the mirror with an oblique near plane (the setup's
    /// projection); false: the camera's own projection, and the host clips
    /// with `refl_planar_setup.clip_plane`. Default true.
    pub oblique: bool,
    /// Coverage: the largest distance of a pixel's point from the plane,
    /// relative to its linear depth (plus the depth buffer's own
    /// quantization); finite, >= 0. Default 1e-3.
    pub plane_tolerance: f32,
    /// Coverage: the smallest |cos| of the angle between a pixel's normal
    /// and the plane's, in [0, 1]; 0 turns the test off. Default 0.99.
    pub normal_cos: f32,
    /// Resolve: render texels whose linear depth differs from the anchor
    /// texel's by more than this fraction of it are not blended; >= 0,
    /// +infinity allowed. Default 0.05.
    pub edge_threshold: f32,
}

impl From<PlanarOptions> for refl_planar_options {
    fn from(o: PlanarOptions) -> Self {
        Self {
            scale: o.scale,
            oblique: o.oblique,
            plane_tolerance: o.plane_tolerance,
            normal_cos: o.normal_cos,
            edge_threshold: o.edge_threshold,
        }
    }
}

impl From<refl_planar_options> for PlanarOptions {
    fn from(o: refl_planar_options) -> Self {
        Self {
            scale: o.scale,
            oblique: o.oblique,
            plane_tolerance: o.plane_tolerance,
            normal_cos: o.normal_cos,
            edge_threshold: o.edge_threshold,
        }
    }
}

/// The pass's defaults: full resolution, oblique clipping, points within
/// 1e-3 of their depth of the plane, normals within about 8 degrees,
/// blending across depth changes up to 5%.
#[no_mangle]
pub extern "C" fn refl_planar_options_default() -> refl_planar_options {
    PlanarOptions::default().into()
}

/// The mirror: its plane and, optionally, which pixels belong to it.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_planar_mirror {
    /// The mirror's plane, either orientation (the pass orients it toward
    /// the eye).
    pub plane: refl_plane,
    /// Optional object ids, the G-buffer's size: only pixels whose id is
    /// `id` are covered. Absent when `data` is NULL (then only the plane
    /// test and the G-buffer's mask decide).
    pub ids: refl_image_u32,
    /// The mirror's id in `ids`.
    pub id: u32,
}

/// A half-open pixel rectangle [x0, x1) x [y0, y1); all zero when empty.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_planar_rect {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl From<PlanarRect> for refl_planar_rect {
    fn from(r: PlanarRect) -> Self {
        Self {
            x0: r.x0,
            y0: r.y0,
            x1: r.x1,
            y1: r.y1,
        }
    }
}

/// Everything a host needs to render the planar reflection.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_planar_setup {
    /// The camera to render the reflection with: the mirrored view, the
    /// G-buffer camera's fov_y, near and far, the render's size (the
    /// G-buffer's divided by `scale`, rounded up).
    pub camera: refl_camera,
    /// The projection (view to clip space) the render must use: with
    /// `oblique`, its near plane is the mirror (depth clipping removes what
    /// lies behind it) and its depth is in the G-buffer's convention
    /// ([0, 1] for a linear G-buffer, whose render stores linear depth);
    /// else (or when nothing is covered) the camera's own projection.
    pub projection: refl_mat4,
    /// The mirror plane oriented toward the eye: keep what lies on its
    /// positive side (a user clip plane, world space).
    pub clip_plane: refl_plane,
    /// The same plane in the render camera's view space, (a, b, c, d) with
    /// a x + b y + c z + d = 0.
    pub view_clip_plane: refl_vec4,
    /// The render's view contains a reflection: flip the front-face test
    /// (or cull nothing).
    pub flip_winding: bool,
    /// Some pixel is covered; false: skip the mirrored render.
    pub covered: bool,
    /// Number of covered pixels.
    pub covered_pixels: u32,
    /// The covered pixels' bounding rectangle (G-buffer pixels).
    pub rect: refl_planar_rect,
    /// The render texels the resolve reads (the render's scissor).
    pub scissor: refl_planar_rect,
}

/// What the pass says about a pixel (`refl_planar_texel.status`, the
/// bytes of `refl_planar_cover_rows`, `refl_host_ray.status` of the rays
/// of `refl_planar_resolve_rows`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_planar_status {
    /// Not the mirror's id, mask 0, or a row the call did not write.
    Skipped = 0,
    /// No usable surface: sky, NaN depth, zero or non-finite normal.
    NoSurface = 1,
    /// A surface not on the plane (or any surface when the eye lies on
    /// the plane).
    OffPlane = 2,
    /// On the plane (refl_planar_cover_rows).
    Covered = 3,
    /// Covered; the render has a surface at the pixel's reflection.
    Hit = 4,
    /// Covered; the render has none: the reflection is the environment
    /// (the host's probe). The pixel's ray goes to the host list.
    Environment = 5,
}

impl From<PlanarStatus> for refl_planar_status {
    fn from(s: PlanarStatus) -> Self {
        match s {
            PlanarStatus::Skipped => Self::Skipped,
            PlanarStatus::NoSurface => Self::NoSurface,
            PlanarStatus::OffPlane => Self::OffPlane,
            PlanarStatus::Covered => Self::Covered,
            PlanarStatus::Hit => Self::Hit,
            PlanarStatus::Environment => Self::Environment,
        }
    }
}

/// One pixel of the resolve.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_planar_texel {
    /// A `refl_planar_status`.
    pub status: u32,
    /// Where the pixel's reflected ray crosses the render (render pixels);
    /// 0 unless HIT or ENVIRONMENT.
    pub pixel: refl_vec2,
    /// Column of the render texel that answers the pixel (the one holding
    /// `pixel`; reshade its primitive with a visibility buffer). 0 unless
    /// HIT or ENVIRONMENT.
    pub texel_x: u32,
    /// Row of that texel.
    pub texel_y: u32,
    /// Distance from the mirror to the reflected surface along the
    /// reflected ray; 0 unless HIT. Always finite: a distance beyond the
    /// float range (a render depth near FLT_MAX) saturates at FLT_MAX.
    pub t: f32,
}

/// Counts of one `refl_planar_cover_rows` or `refl_planar_resolve_rows`
/// call.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_planar_stats {
    /// Covered pixels.
    pub covered: u32,
    /// Resolve: pixels whose reflection the render has a surface for.
    pub hits: u32,
    /// Resolve: pixels whose reflection is the environment.
    pub environment: u32,
    /// Resolve: rays handed to the host (the environment pixels).
    pub host_rays: u32,
    /// Of those, the ones written to the host list (the first ones in
    /// row-major order).
    pub host_rays_written: u32,
    /// Bounding rectangle of the band's covered pixels (merge bands, then
    /// their scissor is that of the whole).
    pub rect: refl_planar_rect,
}

impl From<PlanarStats> for refl_planar_stats {
    fn from(s: PlanarStats) -> Self {
        Self {
            covered: s.covered,
            hits: s.hits,
            environment: s.environment,
            host_rays: s.host_rays,
            host_rays_written: s.host_rays_written,
            rect: s.rect.into(),
        }
    }
}

/// The host's mirrored render, drawn through `refl_planar_setup.camera`
/// and `.projection`: its size is the setup camera's.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_planar_render {
    /// Depth as the setup's projection writes it in the G-buffer's
    /// convention (linear view depth of the setup camera for a linear
    /// G-buffer); NaN, or at or beyond the far value (the cleared value),
    /// marks a texel without a surface.
    pub depth: refl_image_f32,
    /// Optional color (linear RGB), the depth's size; NULL `data`: none.
    pub color: refl_image_vec3,
}

/// The pass from the C descriptors (validated together).
///
/// # Safety
/// The G-buffer's and the ids' images readable for their `len` texels for
/// `'a`, not written meanwhile.
unsafe fn pass<'a>(
    g: &refl_gbuffer,
    m: &refl_planar_mirror,
    o: &refl_planar_options,
) -> Result<PlanarPass<'a>, Error> {
    // SAFETY: caller contract.
    let gb = unsafe { gbuffer(g) }?;
    let plane = Plane::try_from(&m.plane).map_err(|e| {
        fail(
            e,
            format_args!("`mirror.plane`: not finite, or a zero normal"),
        )
    })?;
    let p = PlanarPass::try_new(gb, plane, (*o).into()).map_err(|e| {
        if e == Error::InvalidArgument {
            fail(
                e,
                format_args!("`options`: a value out of its range (refl_planar_options)"),
            )
        } else {
            e
        }
    })?;
    if m.ids.data.is_null() {
        return Ok(p);
    }
    // SAFETY: caller contract.
    let ids = unsafe { m.ids.view() }?;
    p.try_with_ids(ids, m.id)
        .map_err(|e| fail(e, format_args!("`mirror.ids` is not the camera's size")))
}

/// Reads the three inputs every planar call takes and builds the pass.
///
/// # Safety
/// Each pointer NULL or readable; the images they describe readable for
/// their `len` texels for `'a`, not written meanwhile.
unsafe fn inputs<'a>(
    gbuffer: *const refl_gbuffer,
    mirror: *const refl_planar_mirror,
    options: *const refl_planar_options,
) -> Result<(refl_gbuffer, refl_planar_mirror, PlanarPass<'a>), Error> {
    // SAFETY: caller contract.
    let (g, m, o) = unsafe {
        (
            read(gbuffer, "gbuffer")?,
            read(mirror, "mirror")?,
            read(options, "options")?,
        )
    };
    // SAFETY: caller contract.
    let p = unsafe { pass(&g, &m, &o) }?;
    Ok((g, m, p))
}

/// The byte ranges of the G-buffer's and the mirror's images.
fn input_ranges(g: &refl_gbuffer, m: &refl_planar_mirror) -> [(usize, usize); 7] {
    let mut r = [(0usize, 0usize); 7];
    r[..6].copy_from_slice(&gbuffer_ranges(g));
    if !m.ids.data.is_null() {
        r[6] = (m.ids.data as usize, m.ids.len.saturating_mul(4));
    }
    r
}

/// Sets up a frame: validates the G-buffer, the mirror and the options,
/// orients the plane toward the eye, builds the mirrored camera at the
/// render's size, the projection the render must use and the clip plane,
/// and counts the covered pixels with their rectangle and the render's
/// scissor (one pass over the G-buffer; `refl_core::planar` documents the
/// coverage rule), into `*out`. When nothing is covered (`covered` false:
/// the mirror is hidden, off screen, or the eye lies on its plane) skip
/// the mirrored render.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `gbuffer`, `mirror`,
/// `options` or a required image is NULL; `REFL_STATUS_INSUFFICIENT_SIZE`
/// if an image's `len` is too small; `REFL_STATUS_INVALID_ARGUMENT` for an
/// option out of range, an unknown convention or normal space, an image
/// (ids included) not of the camera's size, a misaligned pointer, `out`
/// overlapping an image, or a non-finite plane; `REFL_STATUS_DEGENERATE_GEOMETRY` for a zero plane
/// normal; the camera's status if it is invalid. Nothing is written on
/// error.
///
/// # Safety
/// `out` NULL or writable; `gbuffer`, `mirror` and `options` NULL or
/// readable, their images readable for their `len` texels and not written
/// during the call.
#[no_mangle]
pub unsafe extern "C" fn refl_planar_prepare(
    out: *mut refl_planar_setup,
    gbuffer: *const refl_gbuffer,
    mirror: *const refl_planar_mirror,
    options: *const refl_planar_options,
) -> refl_status {
    let out_at = out as usize;
    guard("refl_planar_prepare", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let (g, m, p) = unsafe { inputs(gbuffer, mirror, options) }?;
        disjoint(
            &[(out_at, core::mem::size_of::<refl_planar_setup>())],
            &input_ranges(&g, &m),
        )?;
        let s = p.prepare();
        let v = refl_planar_setup {
            camera: (&s.camera).into(),
            projection: s.projection.into(),
            clip_plane: (&s.clip_plane).into(),
            view_clip_plane: refl_vec4 {
                x: s.view_clip_plane.x,
                y: s.view_clip_plane.y,
                z: s.view_clip_plane.z,
                w: s.view_clip_plane.w,
            },
            flip_winding: s.flip_winding,
            covered: s.covered,
            covered_pixels: s.covered_pixels,
            rect: s.rect.into(),
            scissor: s.scissor.into(),
        };
        // SAFETY: caller contract.
        unsafe { out.write(v) };
        Ok(())
    })
}

/// The rows of a G-buffer-sized call: the range checked against the
/// height and the output length against the image.
fn rows_and_len(
    rows: refl_row_range,
    w: u32,
    h: u32,
    out_len: usize,
    need_out: bool,
) -> Result<RowRange, Error> {
    let r = rows.within(h)?;
    let need = (w as usize)
        .checked_mul(h as usize)
        .ok_or(Error::InvalidArgument)?;
    if need_out && out_len < need {
        return Err(fail(
            Error::InsufficientSize,
            format_args!("`out_len` is {out_len}, a {w}x{h} image needs {need}"),
        ));
    }
    Ok(r)
}

/// Writes the coverage of the rows `rows`: for each pixel of those rows a
/// `refl_planar_status` byte (SKIPPED, NO_SURFACE, OFF_PLANE or COVERED)
/// to `out[y * width + x]` (`out` holds the whole image, row stride
/// `width`; only the band's rows are written; `out` may be NULL with
/// `out_len` 0 for the counts alone), and the counts with the band's
/// covered rectangle to `*out_stats`. Bands are independent.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats`, `gbuffer`, `mirror`,
/// `options`, a required image, or `out` with a non-zero `out_len` is
/// NULL; `REFL_STATUS_INSUFFICIENT_SIZE` if `out` is given and
/// `out_len < width * height`, or an image's `len` is too small;
/// `REFL_STATUS_INVALID_ARGUMENT` for rows reversed or beyond the height,
/// outputs overlapping each other or the inputs, and the cases of
/// `refl_planar_prepare`. Nothing is written on error.
///
/// # Safety
/// `out_stats` NULL or writable; `out` NULL or writable for `out_len`
/// bytes; the rest as `refl_planar_prepare`. No other thread writes the
/// rows of `out` this call writes.
#[no_mangle]
pub unsafe extern "C" fn refl_planar_cover_rows(
    out_stats: *mut refl_planar_stats,
    out: *mut u8,
    out_len: usize,
    gbuffer: *const refl_gbuffer,
    mirror: *const refl_planar_mirror,
    options: *const refl_planar_options,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_planar_cover_rows", || {
        let stats_out = Out::new(out_stats, "out_stats")?;
        let with_out = !(out.is_null() && out_len == 0);
        let out_bytes = if with_out {
            check_buffer(out.cast_const(), out_len, "out")?
        } else {
            0
        };
        // SAFETY: caller contract.
        let (g, m, p) = unsafe { inputs(gbuffer, mirror, options) }?;
        let (w, h) = (p.gbuffer().width(), p.gbuffer().height());
        let rows = rows_and_len(rows, w, h, out_len, with_out)?;
        disjoint(
            &[
                (out as usize, out_bytes),
                (
                    out_stats as usize,
                    core::mem::size_of::<refl_planar_stats>(),
                ),
            ],
            &input_ranges(&g, &m),
        )?;
        let st = p.try_cover_rows(rows, &mut |x, y, s| {
            if with_out {
                let i = y as usize * w as usize + x as usize;
                // SAFETY: `i < w * h <= out_len` bytes, writable by
                // contract (checked non-null, size fits isize); this
                // call's rows only.
                unsafe { out.add(i).write(s as u8) };
            }
        })?;
        // SAFETY: caller contract.
        unsafe { stats_out.write(st.into()) };
        Ok(())
    })
}

/// Where a C resolve's results go.
struct Sink<'a> {
    texels: *mut refl_planar_texel,
    width: usize,
    color: Option<refl_core::ImageViewMut<'a, [f32; 3]>>,
    host: *mut refl_host_ray,
    host_len: usize,
}

impl PlanarSink for Sink<'_> {
    fn texel(&mut self, x: u32, y: u32, t: &PlanarTexel, color: [f32; 3]) {
        let i = y as usize * self.width + x as usize;
        let v = refl_planar_texel {
            status: refl_planar_status::from(t.status) as u32,
            pixel: t.pixel.into(),
            texel_x: t.texel[0],
            texel_y: t.texel[1],
            t: t.t,
        };
        // SAFETY: `i` indexes the image's texels, writable (checked by the
        // caller of `try_resolve_rows` against `out_len`).
        unsafe { self.texels.add(i).write(v) };
        if let Some(c) = self.color.as_mut().and_then(|c| c.get_mut(x, y)) {
            *c = color;
        }
    }

    fn host(&mut self, index: u32, r: &PlanarRay) -> bool {
        let v = refl_host_ray {
            x: r.x,
            y: r.y,
            origin: r.origin.into(),
            dir: r.dir.into(),
            t_min: 0.0,
            t_max: f32::INFINITY,
            status: refl_planar_status::Environment as u32,
        };
        // SAFETY: `host` writable for `host_len` entries (checked by
        // `refl_planar_resolve_rows`).
        unsafe { put_host_ray(self.host, self.host_len, index, v) }
    }
}

/// Resolves the rows `rows` against the host's mirrored render: for each
/// pixel of those rows writes its `refl_planar_texel` to
/// `out[y * width + x]` (`out` holds the whole image, row stride `width`;
/// only the band's rows are written), its reflection color to `color` if
/// `color.data` is not NULL (needs a render color; black unless HIT: at
/// full resolution the render's texel, at reduced resolution the
/// depth-guided bilinear mean that never blends across a depth edge beyond
/// `edge_threshold`), and appends the ENVIRONMENT pixels' reflected rays to
/// `host` (up to `host_len`; NULL with 0 allowed; origin on the mirror,
/// t_min 0, t_max +infinity, status `REFL_PLANAR_STATUS_ENVIRONMENT`) in
/// row-major order. The counts go to `*out_stats`. Bands are independent:
/// split the rows (`refl_image_row_band`) across threads, each with its own
/// `host` list.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats`, `out`, `gbuffer`,
/// `mirror`, `options`, `render`, a required image, or `host` with a
/// non-zero `host_len` is NULL; `REFL_STATUS_INSUFFICIENT_SIZE` if
/// `out_len < width * height` or an image's `len` is too small;
/// `REFL_STATUS_INVALID_ARGUMENT` for rows reversed or beyond the height,
/// a render not of the setup camera's size, `color` not of the G-buffer's
/// size or given without a render color, outputs overlapping each other
/// or the inputs, and the cases of `refl_planar_prepare`. Nothing is
/// written on error.
///
/// # Safety
/// `out_stats` NULL or writable; `out` NULL or writable for `out_len`
/// texels; `color.data` NULL or writable for `color.len` texels; `host`
/// NULL or writable for `host_len` entries; `render` NULL or readable, its
/// images readable for their `len` texels; the rest as
/// `refl_planar_prepare`. No other thread writes the rows of `out` and
/// `color` this call writes.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_planar_resolve_rows(
    out_stats: *mut refl_planar_stats,
    out: *mut refl_planar_texel,
    out_len: usize,
    color: refl_image_vec3_mut,
    host: *mut refl_host_ray,
    host_len: usize,
    gbuffer: *const refl_gbuffer,
    mirror: *const refl_planar_mirror,
    options: *const refl_planar_options,
    render: *const refl_planar_render,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_planar_resolve_rows", || {
        let stats_out = Out::new(out_stats, "out_stats")?;
        let out_bytes = check_buffer(out.cast_const(), out_len, "out")?;
        let host_bytes = if host_len == 0 && host.is_null() {
            0
        } else {
            check_buffer(host.cast_const(), host_len, "host")?
        };
        // SAFETY: caller contract.
        let (g, m, p) = unsafe { inputs(gbuffer, mirror, options) }?;
        // SAFETY: caller contract.
        let r = unsafe { read(render, "render") }?;
        let (w, h) = (p.gbuffer().width(), p.gbuffer().height());
        let rows = rows_and_len(rows, w, h, out_len, true)?;
        // SAFETY: caller contract.
        let depth = unsafe { r.depth.view() }?;
        let rcolor = if r.color.data.is_null() {
            None
        } else {
            // SAFETY: caller contract.
            Some(unsafe { r.color.view() }?)
        };
        let (rw, rh) = p.render_size();
        let rv = PlanarRender::try_new(depth, rcolor).map_err(|e| {
            fail(
                e,
                format_args!("`render.color` is not the render depth's size"),
            )
        })?;
        if depth.width() != rw || depth.height() != rh {
            return Err(fail(
                Error::InvalidArgument,
                format_args!(
                    "`render.depth` is {}x{}, the setup's camera is {rw}x{rh}",
                    depth.width(),
                    depth.height()
                ),
            ));
        }
        if !color.data.is_null()
            && (r.color.data.is_null() || color.width != w || color.height != h)
        {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`color` needs a render color and the G-buffer's size"),
            ));
        }
        // Aliasing: the outputs must not overlap each other or the inputs.
        let color_bytes = if color.data.is_null() {
            0
        } else {
            byte_len::<[f32; 3]>(color.data as usize, color.len)?
        };
        let mut ins = [(0usize, 0usize); 9];
        ins[..7].copy_from_slice(&input_ranges(&g, &m));
        ins[7] = (r.depth.data as usize, r.depth.len.saturating_mul(4));
        if !r.color.data.is_null() {
            ins[8] = (r.color.data as usize, r.color.len.saturating_mul(12));
        }
        disjoint(
            &[
                (out as usize, out_bytes),
                (host as usize, host_bytes),
                (color.data as usize, color_bytes),
                (
                    out_stats as usize,
                    core::mem::size_of::<refl_planar_stats>(),
                ),
            ],
            &ins,
        )?;
        let color_view = if color.data.is_null() {
            None
        } else {
            // SAFETY: caller contract (the band's rows writable, not
            // accessed by others during the call).
            Some(unsafe { color.band_mut(rows) }?)
        };
        let mut sink = Sink {
            texels: out,
            width: w as usize,
            color: color_view,
            host,
            host_len,
        };
        let st = p.try_resolve_rows(&rv, rows, &mut sink)?;
        // SAFETY: caller contract.
        unsafe { stats_out.write(st.into()) };
        Ok(())
    })
}
