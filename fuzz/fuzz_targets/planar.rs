//! The planar mirror pass (issue 13): `refl_planar_options_default`,
//! `refl_planar_prepare`, `refl_planar_cover_rows`,
//! `refl_planar_resolve_rows`.
//!
//! The G-buffer of [`FuzzGBuffer`] (depth in every convention, normals in
//! both spaces, optional mask and the images the pass does not read, each
//! sometimes of the wrong size, short, NULL or misaligned), a mirror plane
//! (mostly through a pixel's world point, sometimes arbitrary, degenerate,
//! NaN/Inf, huge or tiny), optional object ids, fuzzed options, a host
//! render of fuzzed size, depth and color, output, color and host-list
//! buffers and row bands. Checked: the NULL and error rules (nothing
//! written on error, inputs never written); valid inputs accepted and
//! accepted inputs valid (options in their documented ranges, defaults the
//! documented values); the setup (camera: the mirrored view, the G-buffer
//! camera's fov/near/far at the render's size; projection: the camera's own
//! or the oblique one; clip plane oriented toward the eye; view clip plane;
//! winding; covered count and rectangle equal to the coverage's, scissor
//! in the render); coverage bytes in range, only the band's rows written,
//! the skip/no-surface/on-plane rules; resolve statuses consistent with the
//! coverage, fields zero where documented, anchors in the render's
//! scissor, empty render texels giving ENVIRONMENT, colors (the render's
//! texel at full resolution, black unless HIT, within the neighbors'
//! range), stats equal to what the outputs hold, the host list (row-major,
//! the ENVIRONMENT pixels, origin on the mirror, unit reflected direction,
//! [0, +inf)); two bands give the same bytes as one call; a render of
//! another size than the setup camera's is refused.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

const SKIPPED: u32 = 0;
const NO_SURFACE: u32 = 1;
const OFF_PLANE: u32 = 2;
const COVERED: u32 = 3;
const HIT: u32 = 4;
const ENVIRONMENT: u32 = 5;

// ---------------------------------------------------------------------------
// Reading the late parts of the input: once the bytes run out (the
// G-buffer takes most of a short input), every choice is the plain valid
// one, so that short inputs reach the resolve.

trait Late {
    fn ch(&mut self, k: u8) -> bool;
    fn kind(&mut self) -> PtrKind;
    fn rows_(&mut self, h: u32) -> refl_row_range;
    fn len_(&mut self, need: usize) -> usize;
}

impl Late for Bytes<'_> {
    fn ch(&mut self, k: u8) -> bool {
        !self.is_empty() && self.chance(k)
    }
    fn kind(&mut self) -> PtrKind {
        if self.is_empty() { PtrKind::Valid } else { self.ptr_kind() }
    }
    fn rows_(&mut self, h: u32) -> refl_row_range {
        if self.is_empty() { refl_row_range { begin: 0, end: h } } else { self.rows(h) }
    }
    fn len_(&mut self, need: usize) -> usize {
        if self.is_empty() { need } else { self.len_for(need) }
    }
}

/// [`image_buf`] with the late choices.
fn late_image_buf<T: Copy>(
    b: &mut Bytes,
    width: u32,
    height: u32,
    stride: u32,
    mut f: impl FnMut(u32, u32) -> T,
    pad: T,
) -> Buf<T> {
    let need = required_len(width, height, stride).unwrap_or(16).min(1 << 16);
    let len = b.len_(need);
    let kind = b.kind();
    let st = stride.max(1) as usize;
    Buf::from_fn(len, kind, |i| {
        let (x, y) = ((i % st) as u32, (i / st) as u32);
        if x < width && y < height { f(x, y) } else { pad }
    })
}

// ---------------------------------------------------------------------------
// Inputs.

fn options(b: &mut Bytes) -> refl_planar_options {
    let mut o = refl_planar_options_default();
    if b.ch(96) {
        o.scale = match b.u8() {
            0..=7 => b.pick(&[0, 49, 1 << 16, u32::MAX]),
            k => 1 + u32::from(k) % 5,
        };
    }
    if b.ch(48) {
        o.oblique = b.bool();
    }
    if b.ch(64) {
        o.plane_tolerance = match b.u8() % 4 {
            0 => b.f32_in(-0.01, 0.1),
            1 => 0.0,
            _ => b.f32_in(0.0, 0.02),
        };
    }
    if b.ch(64) {
        o.normal_cos = match b.u8() % 4 {
            0 => 0.0,
            1 => b.f32_in(-0.1, 1.1),
            _ => b.f32_in(0.9, 1.0),
        };
    }
    if b.ch(48) {
        o.edge_threshold = match b.u8() % 4 {
            0 => f32::INFINITY,
            1 => b.f32_in(-0.1, 0.0),
            _ => b.f32_in(0.0, 0.5),
        };
    }
    o
}

/// The options' documented ranges.
fn options_in_range(o: &refl_planar_options) -> bool {
    o.scale >= 1
        && o.plane_tolerance.is_finite()
        && o.plane_tolerance >= 0.0
        && (0.0..=1.0).contains(&o.normal_cos)
        && o.edge_threshold >= 0.0
}

/// A mirror plane: mostly through the world point of a pixel of the
/// G-buffer (so that some pixels lie on it), with the floor's, the pixel's
/// or a fuzzed normal; sometimes arbitrary or hostile.
fn plane(b: &mut Bytes, fg: &FuzzGBuffer) -> refl_plane {
    let img = &fg.img;
    let mode = b.u8();
    let pick_own = b.u8() % 4 == 0;
    let normal = match b.u8() % 4 {
        0 | 1 => v3(0.0, 1.0, 0.0),
        2 => b.dir3(),
        _ => v3(0.0, 0.0, 1.0),
    };
    if mode < 200 && img.buf.usable() && img.width <= MAX_SIDE && img.height <= MAX_SIDE && img.width > 0 && img.height > 0 && img.stride >= img.width {
        // The first pixel from a fuzzed start (bottom rows first: the
        // floor) whose depth unprojects to a finite point.
        let (w, h) = (img.width, img.height);
        let n = w * h;
        let start = b.below(n);
        let mut found = None;
        for k in 0..n {
            let idx = (start + k) % n;
            let (x, y) = (idx % w, h - 1 - idx / w);
            let i = y as usize * img.stride as usize + x as usize;
            if i >= img.buf.len() {
                continue;
            }
            let mut p = refl_vec3::default();
            let px = refl_vec2 { x: x as f32 + 0.5, y: y as f32 + 0.5 };
            // SAFETY: pointers valid.
            let s = unsafe { refl_camera_unproject(&mut p, &img.cam, px, img.texel(x, y), img.conv) };
            let z = decode(&img.cam, img.texel(x, y), img.conv);
            if s == refl_status::Ok && finite3(p) && z.is_some_and(|z| z < img.cam.z_far) {
                found = Some((x, y, p));
                break;
            }
        }
        if let Some((x, y, p)) = found {
            // The pixel's own world normal (when usable), else the choice.
            let mut iv = refl_mat4 { m: [0.0; 16] };
            // SAFETY: pointers valid.
            let iv = (unsafe { refl_camera_inverse_view(&mut iv, &img.cam) } == refl_status::Ok).then_some(iv);
            let own = (fg.normals.0.usable()
                && x < fg.normals.1
                && y < fg.normals.2
                && fg.normals.3 >= fg.normals.1
                && (y as usize * fg.normals.3 as usize + x as usize) < fg.normals.0.len())
            .then(|| world_normal(fg, iv.as_ref(), x, y))
            .flatten();
            let n = match (pick_own, own) {
                (true, Some(o)) => v3(o[0] as f32, o[1] as f32, o[2] as f32),
                _ => normal,
            };
            let mut pl = refl_plane::default();
            // SAFETY: pointers valid.
            if unsafe { refl_plane_from_point_normal(&mut pl, p, n) } == refl_status::Ok {
                if b.ch(32) {
                    // The other orientation.
                    pl = refl_plane { normal: v3(-pl.normal.x, -pl.normal.y, -pl.normal.z), d: -pl.d };
                }
                if b.ch(24) {
                    // Not unit length (the pass normalizes).
                    let k = b.pick(&[1e-20f32, 1e-3, 3.0, 1e18]);
                    pl = refl_plane { normal: v3(pl.normal.x * k, pl.normal.y * k, pl.normal.z * k), d: pl.d * k };
                }
                return pl;
            }
        }
    }
    match mode % 4 {
        0 => refl_plane { normal: b.vec3_in(-1.0, 1.0), d: b.f32_any() },
        1 => refl_plane { normal: v3(0.0, 0.0, 0.0), d: b.f32_any() },
        _ => refl_plane { normal, d: b.f32_in(-2.0, 2.0) },
    }
}

/// The plane normalized in f64 (None if not finite, zero or not
/// representable: the documented refusals).
fn unit_plane(p: &refl_plane) -> Option<([f64; 3], f64)> {
    if !(finite3(p.normal) && p.d.is_finite()) {
        return None;
    }
    let l = len3(p.normal);
    if !(l > 0.0) {
        return None;
    }
    let d = f64::from(p.d) / l;
    if !(d.abs() <= f64::from(f32::MAX)) {
        return None;
    }
    let n = d3(p.normal).map(|v| v / l);
    Some((n, d))
}

/// Optional object ids (`data` NULL: absent).
struct Ids {
    buf: Buf<u32>,
    w: u32,
    h: u32,
    stride: u32,
    id: u32,
}

fn ids(b: &mut Bytes, w: u32, h: u32) -> Ids {
    if !b.ch(64) {
        return Ids { buf: Buf::sentinel(0, PtrKind::Null), w: 0, h: 0, stride: 0, id: b.u32() };
    }
    let (iw, ih) = if b.ch(16) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (w, h) };
    let stride = if b.ch(24) { b.stride(iw) } else { iw };
    let id = u32::from(b.u8() % 4);
    let seed = u32::from(b.u8());
    let buf = late_image_buf(b, iw, ih, stride, |x, y| (x / 3 + y / 2 + seed) % 4, u32::MAX);
    Ids { buf, w: iw, h: ih, stride, id }
}

impl Ids {
    fn present(&self) -> bool {
        !self.buf.is_null()
    }

    fn valid(&self, w: u32, h: u32) -> bool {
        !self.present()
            || (self.buf.usable()
                && self.w == w
                && self.h == h
                && required_len(self.w, self.h, self.stride).is_some_and(|n| self.buf.len() >= n))
    }

    fn image(&self) -> refl_image_u32 {
        refl_image_u32 { data: self.buf.cptr(), len: self.buf.len(), width: self.w, height: self.h, stride: self.stride }
    }

    fn at(&self, x: u32, y: u32) -> u32 {
        self.buf.get(y as usize * self.stride as usize + x as usize)
    }
}

/// Whether every present image of the G-buffer is usable: the depth image
/// valid, normals of the camera's size, known normal space, optional images
/// absent (NULL) or of the camera's size and long enough.
fn gbuffer_valid(fg: &FuzzGBuffer) -> bool {
    let (w, h) = (fg.img.width, fg.img.height);
    let img_ok = |usable: bool, len: usize, iw: u32, ih: u32, st: u32| {
        usable && iw == w && ih == h && required_len(iw, ih, st).is_some_and(|n| len >= n)
    };
    let opt_ok = |null: bool, usable: bool, len: usize, iw: u32, ih: u32, st: u32| null || img_ok(usable, len, iw, ih, st);
    fg.img.valid()
        && img_ok(fg.normals.0.usable(), fg.normals.0.len(), fg.normals.1, fg.normals.2, fg.normals.3)
        && fg.normal_space <= 1
        && opt_ok(fg.mask.0.is_null(), fg.mask.0.usable(), fg.mask.0.len(), fg.mask.1, fg.mask.2, fg.mask.3)
        && opt_ok(fg.roughness.0.is_null(), fg.roughness.0.usable(), fg.roughness.0.len(), fg.roughness.1, fg.roughness.2, fg.roughness.3)
        && opt_ok(fg.color.0.is_null(), fg.color.0.usable(), fg.color.0.len(), fg.color.1, fg.color.2, fg.color.3)
        && opt_ok(fg.back.0.is_null(), fg.back.0.usable(), fg.back.0.len(), fg.back.1, fg.back.2, fg.back.3)
}

/// The host's mirrored render.
struct Render {
    depth: Buf<f32>,
    dw: u32,
    dh: u32,
    ds: u32,
    color: Buf<refl_vec3>,
    cw: u32,
    ch: u32,
    cs: u32,
}

/// The empty (cleared) render depth of convention `conv`.
fn cleared(conv: u32, far: f32) -> f32 {
    match conv {
        0 => far,
        1 => 1.0,
        _ => 0.0,
    }
}

fn render(b: &mut Bytes, cam: &refl_camera, conv: u32, rw: u32, rh: u32) -> Render {
    let (dw, dh) = if b.ch(12) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (rw, rh) };
    let ds = if b.ch(24) { b.stride(dw) } else { dw };
    let conv = conv.min(2);
    let far = cam.z_far;
    let near = cam.z_near;
    let mode = b.u8() % 6;
    let base = match (b.is_empty(), conv) {
        (true, 0) => near + 5.0,
        (true, _) => 0.5,
        (false, 0) => b.f32_in(near, near + 30.0),
        (false, _) => b.f32_in(0.0, 1.0),
    };
    let spread = b.f32_fine(0.0, if conv == 0 { 5.0 } else { 0.2 });
    let seed = u32::from(b.u8());
    let hostile = b.ch(24).then(|| b.f32_special());
    let depth = late_image_buf(
        b,
        dw,
        dh,
        ds,
        |x, y| {
            let k = x.wrapping_mul(5) ^ y.wrapping_mul(3) ^ seed;
            let v = base + spread * ((k % 7) as f32 / 7.0);
            let v = if conv == 0 { v } else { v.clamp(0.0, 1.0) };
            match mode {
                5 => cleared(conv, far),
                1 => base,
                0 | 2 => {
                    if k % 5 == 0 {
                        cleared(conv, far)
                    } else if k % 11 == 1 {
                        f32::NAN
                    } else if k % 13 == 2 {
                        hostile.unwrap_or(v)
                    } else {
                        v
                    }
                }
                4 => {
                    // A step edge (the depth guide) and holes.
                    if (x + seed) % 4 < 2 { v } else if k % 3 == 0 { cleared(conv, far) } else { v * 1.5 }
                }
                _ => f32::from_bits(k.wrapping_mul(0x9E37_79B9) ^ seed.wrapping_mul(0x85eb_ca6b)), // 3
            }
        },
        f32::NAN,
    );
    let with_color = !b.ch(64);
    let (cw, ch) = if b.ch(8) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (dw, dh) };
    let cs = if b.ch(24) { b.stride(cw) } else { cw };
    let chostile = b.ch(16).then(|| b.f32_special());
    let color = if with_color {
        late_image_buf(
            b,
            cw,
            ch,
            cs,
            |x, y| match chostile {
                Some(v) if (x + y) % 3 == 0 => v3(v, x as f32, -v),
                _ => v3(x as f32 * 0.25, y as f32 * 0.5, 1.0 + (x ^ y) as f32),
            },
            v3(-7.0, -7.0, -7.0),
        )
    } else {
        Buf::sentinel(0, PtrKind::Null)
    };
    Render { depth, dw, dh, ds, color, cw, ch, cs }
}

impl Render {
    fn desc(&self) -> refl_planar_render {
        refl_planar_render {
            depth: img_f32(&self.depth, self.dw, self.dh, self.ds),
            color: refl_image_vec3 { data: self.color.cptr(), len: self.color.len(), width: self.cw, height: self.ch, stride: self.cs },
        }
    }

    /// Whether refl must accept it for a render of `rw x rh`.
    fn valid(&self, rw: u32, rh: u32) -> bool {
        self.depth.usable()
            && self.dw == rw
            && self.dh == rh
            && required_len(self.dw, self.dh, self.ds).is_some_and(|n| self.depth.len() >= n)
            && (self.color.is_null()
                || (self.color.usable()
                    && self.cw == rw
                    && self.ch == rh
                    && required_len(self.cw, self.ch, self.cs).is_some_and(|n| self.color.len() >= n)))
    }

    fn depth_at(&self, x: u32, y: u32) -> f32 {
        self.depth.get(y as usize * self.ds as usize + x as usize)
    }

    fn color_at(&self, x: u32, y: u32) -> refl_vec3 {
        self.color.get(y as usize * self.cs as usize + x as usize)
    }
}

// ---------------------------------------------------------------------------
// Small helpers.

fn same_texel(a: &refl_planar_texel, b: &refl_planar_texel) -> bool {
    a.status == b.status
        && a.pixel.x.to_bits() == b.pixel.x.to_bits()
        && a.pixel.y.to_bits() == b.pixel.y.to_bits()
        && a.texel_x == b.texel_x
        && a.texel_y == b.texel_y
        && a.t.to_bits() == b.t.to_bits()
}

fn rect_empty(r: &refl_planar_rect) -> bool {
    r.x0 >= r.x1 || r.y0 >= r.y1
}

fn rect_union(a: refl_planar_rect, b: refl_planar_rect) -> refl_planar_rect {
    if rect_empty(&a) {
        return b;
    }
    if rect_empty(&b) {
        return a;
    }
    refl_planar_rect { x0: a.x0.min(b.x0), y0: a.y0.min(b.y0), x1: a.x1.max(b.x1), y1: a.y1.max(b.y1) }
}

fn rect_add(r: &mut refl_planar_rect, x: u32, y: u32) {
    *r = rect_union(*r, refl_planar_rect { x0: x, y0: y, x1: x + 1, y1: y + 1 });
}

fn zero_rect(r: &refl_planar_rect) -> bool {
    *r == refl_planar_rect::default()
}

/// `|a - b| <= tol` elementwise, relative to the larger magnitude.
fn close_mat(a: &refl_mat4, b: &refl_mat4, tol: f32) -> bool {
    a.m.iter().zip(&b.m).all(|(x, y)| close(*x, *y, tol))
}

/// The world-space normal of pixel `(x, y)` in f64 (None: zero or not
/// finite, the documented unusable normals).
fn world_normal(fg: &FuzzGBuffer, inv_view: Option<&refl_mat4>, x: u32, y: u32) -> Option<[f64; 3]> {
    let n = fg.normal_at(x, y);
    if !finite3(n) {
        return None;
    }
    let n = d3(n);
    let n = if fg.normal_space == 1 {
        let m = inv_view?;
        let r = mat_mul4(m, [n[0], n[1], n[2], 0.0]);
        [r[0], r[1], r[2]]
    } else {
        n
    };
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    (l > 0.0 && l.is_finite() && n.iter().all(|v| (*v as f32).is_finite())).then(|| n.map(|v| v / l))
}

/// A row band call's host list capacity.
fn n_of(w: u32, h: u32) -> usize {
    w as usize * h as usize
}

/// One `refl_planar_cover_rows` over `rows` into a fresh whole-image buffer.
fn cover(
    g: &refl_gbuffer,
    m: &refl_planar_mirror,
    o: &refl_planar_options,
    rows: refl_row_range,
) -> (refl_status, refl_planar_stats, Vec<u8>) {
    let (w, h) = (g.depth.camera.width, g.depth.camera.height);
    let n = n_of(w, h);
    let mut out = Buf::<u8>::sentinel(n, PtrKind::Valid);
    let mut st = refl_planar_stats::default();
    // SAFETY: buffers valid for their lengths; inputs as fuzzed.
    let s = unsafe { refl_planar_cover_rows(&mut st, out.ptr(), n, g, m, o, rows) };
    no_panic(s, "refl_planar_cover_rows");
    (s, st, out.to_vec())
}

/// One `refl_planar_resolve_rows` over `rows` into fresh valid buffers.
#[allow(clippy::type_complexity)]
fn resolve(
    g: &refl_gbuffer,
    m: &refl_planar_mirror,
    o: &refl_planar_options,
    r: &refl_planar_render,
    with_color: bool,
    host_len: usize,
    rows: refl_row_range,
) -> (refl_status, refl_planar_stats, Vec<refl_planar_texel>, Vec<refl_vec3>, Vec<refl_host_ray>) {
    let (w, h) = (g.depth.camera.width, g.depth.camera.height);
    let n = n_of(w, h);
    let mut out = Buf::<refl_planar_texel>::sentinel(n, PtrKind::Valid);
    let mut col = Buf::<refl_vec3>::sentinel(if with_color { n } else { 0 }, if with_color { PtrKind::Valid } else { PtrKind::Null });
    let mut host = Buf::<refl_host_ray>::sentinel(host_len, if host_len > 0 { PtrKind::Valid } else { PtrKind::Null });
    let cm = refl_image_vec3_mut { data: col.ptr(), len: col.len(), width: w, height: h, stride: w };
    let mut st = refl_planar_stats::default();
    // SAFETY: buffers valid for their lengths; inputs as fuzzed.
    let s = unsafe { refl_planar_resolve_rows(&mut st, out.ptr(), n, cm, host.ptr(), host_len, g, m, o, r, rows) };
    no_panic(s, "refl_planar_resolve_rows");
    (s, st, out.to_vec(), if with_color { col.to_vec() } else { Vec::new() }, host.to_vec())
}

// ---------------------------------------------------------------------------

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);

    // Defaults: the documented values, in range.
    let d = refl_planar_options_default();
    assert!(options_in_range(&d), "defaults out of range: {d:?}");
    assert!(
        d.scale == 1 && d.oblique && d.plane_tolerance == 1e-3 && d.normal_cos == 0.99 && d.edge_threshold == 0.05,
        "defaults are not the documented values: {d:?}"
    );

    let fg = FuzzGBuffer::new(&mut b, [160, 200, 200, 200]);
    let img = &fg.img;
    let (w, h) = (img.width, img.height);
    let cam = img.cam;
    let conv = img.conv;
    let g = fg.desc();
    let o = options(&mut b);
    let pl = plane(&mut b, &fg);
    let idm = ids(&mut b, w, h);
    let mirror = refl_planar_mirror { plane: pl, ids: idm.image(), id: idm.id };
    let ids_snap = idm.buf.snapshot();
    let inputs_unchanged = |what: &str| {
        fg.assert_unchanged(what);
        idm.buf.assert_unchanged(&ids_snap, what);
    };
    let gb = Buf::from_slice(&[g], b.kind());
    let mb = Buf::from_slice(&[mirror], b.kind());
    let ob = Buf::from_slice(&[o], b.kind());
    let args_null = gb.is_null() || mb.is_null() || ob.is_null();
    let args_mis = [gb.kind(), mb.kind(), ob.kind()].contains(&PtrKind::Misaligned);
    let images_null = img.buf.is_null() || fg.normals.0.is_null();
    let cam_ok = camera_ok(&cam);
    let uplane = unit_plane(&pl);
    let inputs_valid = gbuffer_valid(&fg) && options_in_range(&o) && uplane.is_some() && idm.valid(w, h);
    // A valid camera and plane whose mirrored camera is not a valid camera
    // (huge coordinates), or a projection that overflows: refusals the
    // header allows ("the camera's status").
    let mirror_cam = {
        let mut mc = zero_camera();
        // SAFETY: pointers valid.
        let s = unsafe { refl_mirror_camera(&mut mc, &cam, &pl) };
        (s == refl_status::Ok).then_some(mc)
    };
    let may_refuse = mirror_cam.is_none() || matrix_may_overflow(&cam, false);
    let (rw, rh) = (w.div_ceil(o.scale.max(1)), h.div_ceil(o.scale.max(1)));

    // 1. Prepare.
    let mut sb = out1::<refl_planar_setup>(b.kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_planar_prepare(sb.ptr(), gb.cptr(), mb.cptr(), ob.cptr()) };
    let req_null = sb.is_null() || args_null;
    let mis = args_mis || sb.kind() == PtrKind::Misaligned;
    null_rules_m(s, req_null, req_null || images_null || idm.buf.is_null(), mis, "refl_planar_prepare");
    on_error_untouched(s, &[("out", sb.is_sentinel(0))], "refl_planar_prepare");
    inputs_unchanged("refl_planar_prepare");
    if !req_null && !mis && inputs_valid && !may_refuse {
        assert_eq!(s, refl_status::Ok, "prepare refused valid input: {}; camera {cam:?} plane {pl:?} options {o:?}", last_error());
    }
    // The setup from valid pointers (the rest of the checks use it).
    let mut setup = unsafe { core::mem::zeroed::<refl_planar_setup>() };
    // SAFETY: pointers valid.
    let ps = unsafe { refl_planar_prepare(&mut setup, &g, &mirror, &o) };
    no_panic(ps, "refl_planar_prepare");
    if s == refl_status::Ok {
        assert_eq!(ps, refl_status::Ok);
        let a = sb.get(0);
        assert!(a == setup || format!("{a:?}") == format!("{setup:?}"), "prepare differs between calls");
    }
    if ps != refl_status::Ok {
        // Everything below needs an accepted frame; the row calls refuse
        // it too (the same validation).
        let mut st = out1::<refl_planar_stats>(PtrKind::Valid);
        let mut out = Buf::<u8>::sentinel(n_of(w, h).min(1 << 16), PtrKind::Valid);
        let rows = b.rows_(h);
        // SAFETY: pointers valid; inputs as fuzzed.
        let s = unsafe { refl_planar_cover_rows(st.ptr(), out.ptr(), out.len(), &g, &mirror, &o, rows) };
        null_rules(s, false, images_null, "refl_planar_cover_rows");
        assert_ne!(s, refl_status::Ok, "cover_rows accepted what prepare refused ({ps:?})");
        on_error_untouched(s, &[("out_stats", st.is_sentinel(0)), ("out", (0..out.len()).all(|i| out.is_sentinel(i)))], "refl_planar_cover_rows");
        inputs_unchanged("refl_planar_cover_rows");
        return;
    }
    assert!(cam_ok, "prepare accepted an invalid camera {cam:?}");
    assert!(inputs_valid, "prepare accepted invalid input: gbuffer {} options {o:?} plane {pl:?} ids {}", gbuffer_valid(&fg), idm.valid(w, h));
    fg.assert_accepted("prepare");
    let (un, ud) = uplane.unwrap();
    let n = n_of(w, h);

    // The setup's promises.
    let sc = setup.camera;
    assert!(camera_ok(&sc), "setup camera invalid: {sc:?}");
    assert!((sc.width, sc.height) == (rw, rh), "setup camera {}x{} for {w}x{h} at scale {}", sc.width, sc.height, o.scale);
    assert!(
        sc.fov_y.to_bits() == cam.fov_y.to_bits() && sc.z_near.to_bits() == cam.z_near.to_bits() && sc.z_far.to_bits() == cam.z_far.to_bits(),
        "setup camera's projection is not the G-buffer camera's"
    );
    if let Some(mc) = mirror_cam {
        assert!(close_mat(&sc.view, &mc.view, 1e-4), "setup view {:?} is not the mirrored view {:?}", sc.view, mc.view);
    }
    let mut mirrored = false;
    // SAFETY: pointers valid.
    assert_eq!(unsafe { refl_camera_is_mirrored(&mut mirrored, &sc) }, refl_status::Ok);
    if !known_f5(&sc) {
        assert_eq!(setup.flip_winding, mirrored, "flip_winding vs refl_camera_is_mirrored");
    }
    assert_eq!(setup.covered, setup.covered_pixels > 0, "covered vs covered_pixels");
    if !setup.covered {
        assert!(zero_rect(&setup.rect) && zero_rect(&setup.scissor), "nothing covered but rect {:?} scissor {:?}", setup.rect, setup.scissor);
    } else {
        let r = setup.rect;
        assert!(!rect_empty(&r) && r.x1 <= w && r.y1 <= h, "rect {r:?} of {w}x{h}");
        assert!(setup.covered_pixels as u64 <= u64::from(r.x1 - r.x0) * u64::from(r.y1 - r.y0), "more covered pixels than the rect holds");
        let s = setup.scissor;
        assert!(!rect_empty(&s) && s.x1 <= rw && s.y1 <= rh, "scissor {s:?} of the {rw}x{rh} render");
    }
    // The clip plane: the mirror plane, unit, oriented toward the eye.
    let cp = setup.clip_plane;
    assert!(finite3(cp.normal) && cp.d.is_finite(), "clip plane not finite {cp:?}");
    assert!((len3(cp.normal) - 1.0).abs() < 1e-5, "clip plane normal not unit {cp:?}");
    let cn = d3(cp.normal);
    let sign = if cn[0] * un[0] + cn[1] * un[1] + cn[2] * un[2] >= 0.0 { 1.0 } else { -1.0 };
    for k in 0..3 {
        assert!((cn[k] - sign * un[k]).abs() < 1e-5, "clip plane {cp:?} is not the mirror's {un:?}");
    }
    assert!((f64::from(cp.d) - sign * ud).abs() <= 1e-5 * (1.0 + ud.abs()), "clip plane d {} vs mirror {ud}", cp.d);
    let eye = eye_of(&cam);
    let moderate = camera_moderate(&cam) && ud.abs() < 1e3;
    // (Finding F24, fixed: a plane given with its normal away from the eye
    // and d != 0 gave the plane mirrored through the origin here.)
    if let (Some(e), true) = (eye, moderate) {
        let de = cn[0] * f64::from(e.x) + cn[1] * f64::from(e.y) + cn[2] * f64::from(e.z) + f64::from(cp.d);
        assert!(de >= -1e-4 * (1.0 + ud.abs() + f64::from(max_abs3(e))), "the eye is on the clip plane's negative side ({de})");
        // The view clip plane: the same plane in the render's view space.
        let vp = setup.view_clip_plane;
        assert!([vp.x, vp.y, vp.z, vp.w].iter().all(|v| v.is_finite()), "view clip plane {vp:?}");
        let p0 = cn.map(|v| -v * f64::from(cp.d));
        let (t1, t2) = if cn[0].abs() < 0.9 { ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]) } else { ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0]) };
        for t in [[0.0; 3], t1, t2] {
            // A point on the plane: p0 plus t projected onto the plane.
            let tn = t[0] * cn[0] + t[1] * cn[1] + t[2] * cn[2];
            let p = [0, 1, 2].map(|k| p0[k] + t[k] - tn * cn[k]);
            let q = mat_mul4(&sc.view, [p[0], p[1], p[2], 1.0]);
            let dv = f64::from(vp.x) * q[0] + f64::from(vp.y) * q[1] + f64::from(vp.z) * q[2] + f64::from(vp.w);
            assert!(dv.abs() < 1e-3 * (1.0 + ud.abs() + f64::from(max_abs3(e))), "view clip plane {vp:?}: a point of the plane {p:?} (view {q:?}) is {dv} off; clip {cp:?} setup camera {sc:?} camera {cam:?} eye {e:?} plane {pl:?}");
        }
    }
    // The projection: the camera's own unless oblique and covered.
    let pconv = if conv == 0 { 1 } else { conv };
    let mut own = refl_mat4 { m: [0.0; 16] };
    if !o.oblique || !setup.covered {
        // SAFETY: pointers valid.
        if unsafe { refl_camera_projection_matrix(&mut own, &sc, pconv) } == refl_status::Ok {
            assert!(close_mat(&setup.projection, &own, 1e-5), "projection {:?} is not the camera's own {own:?}", setup.projection);
        }
    } else {
        // SAFETY: pointers valid.
        let s = unsafe { refl_mirror_oblique_projection(&mut own, &sc, &cp, pconv) };
        assert_eq!(s, refl_status::Ok, "covered, but no oblique projection for the setup camera and clip plane: {}", last_error());
        assert!(close_mat(&setup.projection, &own, 1e-5), "projection {:?} is not the oblique one {own:?}", setup.projection);
    }

    // 2. Coverage of a band with fuzzed buffers.
    let mut inv_view = refl_mat4 { m: [0.0; 16] };
    // SAFETY: pointers valid.
    let inv_view = (unsafe { refl_camera_inverse_view(&mut inv_view, &cam) } == refl_status::Ok).then_some(inv_view);
    let rows = b.rows_(h);
    let counts_only = b.ch(24);
    let out_len = if counts_only { 0 } else { b.len_(n) };
    let mut out = Buf::<u8>::sentinel(out_len, if counts_only { PtrKind::Null } else { b.kind() });
    let mut st = out1::<refl_planar_stats>(b.kind());
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_planar_cover_rows(st.ptr(), out.ptr(), out_len, gb.cptr(), mb.cptr(), ob.cptr(), rows) };
    let req_null = st.is_null() || args_null || (out.is_null() && out_len > 0);
    let mis = args_mis || st.kind() == PtrKind::Misaligned || out.kind() == PtrKind::Misaligned;
    null_rules_m(s, req_null, req_null || out.is_null(), mis, "refl_planar_cover_rows");
    on_error_untouched(
        s,
        &[("out_stats", st.is_sentinel(0)), ("out", (0..out_len).all(|i| out.is_sentinel(i)))],
        "refl_planar_cover_rows",
    );
    inputs_unchanged("refl_planar_cover_rows");
    let rows_ok = rows_ok_for(rows, h);
    let mut band_cover = None;
    if !req_null && !mis && rows_ok && (out.is_null() || out_len >= n) {
        assert_eq!(s, refl_status::Ok, "cover_rows refused valid input: {}", last_error());
    }
    if s == refl_status::Ok {
        assert!(rows_ok, "cover_rows accepted rows {rows:?} of {h}");
        assert!(out.is_null() || out_len >= n, "cover_rows accepted out_len {out_len} < {n}");
        let stats = st.get(0);
        let mut want = refl_planar_stats::default();
        for i in 0..out_len {
            let (x, y) = ((i % w as usize) as u32, (i / w as usize) as u32);
            if i >= n || y < rows.begin || y >= rows.end {
                assert!(out.is_sentinel(i), "cover byte {i} outside rows {rows:?} written");
                continue;
            }
            let c = u32::from(out.get(i));
            assert!(c <= COVERED, "cover byte ({x}, {y}) = {c}");
            if c == COVERED {
                want.covered += 1;
                rect_add(&mut want.rect, x, y);
            }
        }
        if !out.is_null() {
            assert_eq!(stats, want, "cover stats vs bytes");
        }
        band_cover = Some((rows, stats, !out.is_null()));
    }

    // The whole image's coverage: the rules per pixel, and prepare's counts.
    let (cs, cst, cov) = cover(&g, &mirror, &o, refl_row_range { begin: 0, end: h });
    assert_eq!(cs, refl_status::Ok, "whole-image cover_rows refused: {}", last_error());
    assert_eq!((cst.covered, cst.rect), (setup.covered_pixels, setup.rect), "prepare's counts vs cover_rows");
    assert!(cst.hits == 0 && cst.environment == 0 && cst.host_rays == 0 && cst.host_rays_written == 0, "cover stats {cst:?}");
    if let Some((rows, stats, with_out)) = band_cover {
        // The band's counts are the whole coverage's within the band, and
        // its bytes the whole's.
        let mut want = refl_planar_stats::default();
        for y in rows.begin..rows.end {
            for x in 0..w {
                let i = (y * w + x) as usize;
                if u32::from(cov[i]) == COVERED {
                    want.covered += 1;
                    rect_add(&mut want.rect, x, y);
                }
                if with_out {
                    assert_eq!(out.get(i), cov[i], "({x}, {y}): a band's coverage differs from the whole's");
                }
            }
        }
        assert_eq!(stats, want, "a band's cover stats vs the whole's coverage");
    }
    let (nlo, nhi) = (f64::from(cam.z_near), f64::from(cam.z_far));
    for y in 0..h {
        for x in 0..w {
            let c = u32::from(cov[(y * w + x) as usize]);
            let skipped = (idm.present() && idm.at(x, y) != idm.id) || fg.masked(x, y);
            if skipped {
                assert_eq!(c, SKIPPED, "({x}, {y}): not the mirror's id or masked, but {c}");
                continue;
            }
            assert_ne!(c, SKIPPED, "({x}, {y}) skipped: its id and mask are the mirror's");
            let stored = img.texel(x, y);
            let z = decode(&cam, stored, conv);
            let surface = z.is_some_and(|z| f64::from(z) >= nlo && f64::from(z) < nhi);
            let normal = world_normal(&fg, inv_view.as_ref(), x, y);
            let raw = fg.normal_at(x, y);
            if !surface || !finite3(raw) || d3(raw) == [0.0; 3] {
                assert_eq!(c, NO_SURFACE, "({x}, {y}): no surface (depth {stored} -> {z:?}, normal {:?}) but {c}", fg.normal_at(x, y));
                continue;
            }
            let Some(nw) = normal else {
                continue;
            };
            // A usable surface: on the plane or off it, never NO_SURFACE.
            // (Finding F24b, fixed: a finite normal whose square overflowed
            // f32 was read as unusable.)
            assert!(c == OFF_PLANE || c == COVERED, "({x}, {y}): a surface with the finite normal {:?} is {c}", fg.normal_at(x, y));
            let Some(z) = z else { continue };
            let cosn = (nw[0] * un[0] + nw[1] * un[1] + nw[2] * un[2]).abs();
            if c == COVERED {
                assert!(cosn >= f64::from(o.normal_cos) - 1e-5, "({x}, {y}) covered with |cos| {cosn} < {}", o.normal_cos);
            }
            // The point's distance from the plane (moderate cameras).
            if moderate && z < 1e3 {
                let mut p = refl_vec3::default();
                let px = refl_vec2 { x: x as f32 + 0.5, y: y as f32 + 0.5 };
                // SAFETY: pointers valid.
                if unsafe { refl_camera_unproject(&mut p, &cam, px, stored, conv) } != refl_status::Ok || !finite3(p) {
                    continue;
                }
                let pd = d3(p);
                let dist = (pd[0] * un[0] + pd[1] * un[1] + pd[2] * un[2] + ud).abs();
                // The stored depth's quantization: one f32 step decoded.
                let mut q = 0.0f64;
                for nb in [f32::from_bits(stored.to_bits().wrapping_add(1)), f32::from_bits(stored.to_bits().wrapping_sub(1))] {
                    if let Some(zn) = decode(&cam, nb, conv) {
                        let dz = (f64::from(zn) - f64::from(z)).abs();
                        if dz.is_finite() {
                            q = q.max(dz);
                        }
                    }
                }
                let e = eye.map_or(0.0, |e| f64::from(max_abs3(e)));
                let zf = f64::from(z);
                let ray = 1.0 + 4.0 * (f64::from(cam.fov_y) * 0.5).tan() * (1.0 + f64::from(w) / f64::from(h));
                let slack = 2e-4 * (1.0 + e + zf * ray + ud.abs());
                let tol = f64::from(o.plane_tolerance) * zf + 4.0 * q * ray;
                if c == COVERED {
                    assert!(dist <= tol + slack, "({x}, {y}) covered {dist} from the plane (tolerance {tol})");
                } else if setup.covered && cosn >= f64::from(o.normal_cos) + 1e-4 && dist + slack < 0.5 * f64::from(o.plane_tolerance) * zf {
                    panic!("({x}, {y}) on the plane ({dist}, tolerance {}) with |cos| {cosn} but {c}", o.plane_tolerance * z);
                }
            }
        }
    }

    // 3. Resolve a band with fuzzed buffers.
    let rnd = render(&mut b, &sc, conv, rw, rh);
    let rdesc = rnd.desc();
    let rsnap = (rnd.depth.snapshot(), rnd.color.snapshot());
    let rb = Buf::from_slice(&[rdesc], b.kind());
    let rows = b.rows_(h);
    let out_len = if n > 1 << 16 { 16 } else { b.len_(n) };
    let mut out = Buf::<refl_planar_texel>::sentinel(out_len, b.kind());
    let want_color = b.ch(160);
    let (ocw, och) = if b.ch(8) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (w, h) };
    let ocs = if b.ch(24) { b.stride(ocw) } else { ocw };
    let col_len = if want_color { b.len_(required_len(ocw, och, ocs).unwrap_or(16).min(1 << 16)) } else { 0 };
    let mut col = Buf::<refl_vec3>::sentinel(col_len, if want_color { b.kind() } else { PtrKind::Null });
    let cm = refl_image_vec3_mut { data: col.ptr(), len: col_len, width: ocw, height: och, stride: ocs };
    let want_color = want_color && !col.is_null();
    let host_len = match b.u8() % 4 {
        0 => 0,
        1 => b.below(4) as usize,
        _ => n.min(1 << 16),
    };
    let mut host = Buf::<refl_host_ray>::sentinel(host_len, if host_len == 0 && b.bool() { PtrKind::Null } else { b.kind() });
    let mut st = out1::<refl_planar_stats>(b.kind());
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe {
        refl_planar_resolve_rows(st.ptr(), out.ptr(), out_len, cm, host.ptr(), host_len, gb.cptr(), mb.cptr(), ob.cptr(), rb.cptr(), rows)
    };
    let req_null = st.is_null() || out.is_null() || args_null || rb.is_null() || (host.is_null() && host_len > 0);
    let mis = args_mis || [st.kind(), out.kind(), host.kind(), col.kind(), rb.kind()].contains(&PtrKind::Misaligned);
    null_rules_m(s, req_null, req_null || host.is_null() || col.is_null() || rnd.depth.is_null() || rnd.color.is_null(), mis, "refl_planar_resolve_rows");
    on_error_untouched(
        s,
        &[
            ("out_stats", st.is_sentinel(0)),
            ("out", (0..out_len).all(|i| out.is_sentinel(i))),
            ("color", (0..col_len).all(|i| col.is_sentinel(i))),
            ("host", (0..host_len).all(|i| host.is_sentinel(i))),
        ],
        "refl_planar_resolve_rows",
    );
    inputs_unchanged("refl_planar_resolve_rows");
    rnd.depth.assert_unchanged(&rsnap.0, "refl_planar_resolve_rows render depth");
    rnd.color.assert_unchanged(&rsnap.1, "refl_planar_resolve_rows render color");
    let color_ok = !want_color
        || (!rnd.color.is_null()
            && col.usable()
            && ocw == w
            && och == h
            && required_len(ocw, och, ocs).is_some_and(|k| col_len >= k));
    if !req_null && !mis && rows_ok_for(rows, h) && out_len >= n && rnd.valid(rw, rh) && color_ok {
        assert_eq!(s, refl_status::Ok, "resolve_rows refused valid input: {}", last_error());
    }
    if s == refl_status::Ok {
        assert!(rows_ok_for(rows, h), "resolve_rows accepted rows {rows:?} of {h}");
        assert!(out_len >= n, "resolve_rows accepted out_len {out_len} < {n}");
        assert!(rnd.valid(rw, rh), "resolve_rows accepted a render {}x{} (color {}x{}) for a {rw}x{rh} setup camera", rnd.dw, rnd.dh, rnd.cw, rnd.ch);
        assert!(color_ok, "resolve_rows accepted a color output of {ocw}x{och} ({col_len}), render color {}", !rnd.color.is_null());
        let stats = st.get(0);
        let mut want = refl_planar_stats::default();
        let mut env_pixels = Vec::new();
        let rconv = conv.min(2);
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                if y < rows.begin || y >= rows.end {
                    assert!(out.is_sentinel(i), "texel ({x}, {y}) outside rows {rows:?} written");
                    continue;
                }
                let t = out.get(i);
                let c = u32::from(cov[i]);
                assert!(t.status <= ENVIRONMENT && t.status != COVERED, "texel ({x}, {y}) status {}", t.status);
                if c == COVERED {
                    assert!(t.status == HIT || t.status == ENVIRONMENT, "({x}, {y}) covered but {}", t.status);
                } else {
                    assert_eq!(t.status, c, "({x}, {y}) coverage {c} but resolve {}", t.status);
                }
                match t.status {
                    HIT | ENVIRONMENT => {
                        want.covered += 1;
                        rect_add(&mut want.rect, x, y);
                        assert!(t.pixel.x.is_finite() && t.pixel.y.is_finite(), "({x}, {y}) pixel {:?}", t.pixel);
                        assert!(t.texel_x < rw && t.texel_y < rh, "({x}, {y}) texel ({}, {}) outside the {rw}x{rh} render", t.texel_x, t.texel_y);
                        let sc_ = setup.scissor;
                        assert!(
                            t.texel_x >= sc_.x0 && t.texel_x < sc_.x1 && t.texel_y >= sc_.y0 && t.texel_y < sc_.y1,
                            "({x}, {y}) reads texel ({}, {}) outside the scissor {sc_:?}",
                            t.texel_x,
                            t.texel_y
                        );
                        for (p, k, m_) in [(t.pixel.x, t.texel_x, rw), (t.pixel.y, t.texel_y, rh)] {
                            if p >= 0.0 && p < m_ as f32 {
                                assert_eq!(k, p as u32, "({x}, {y}) texel ({}, {}) does not hold {:?}", t.texel_x, t.texel_y, t.pixel);
                            }
                        }
                        if o.scale == 1 {
                            assert!(
                                (t.pixel.x - (x as f32 + 0.5)).abs() < 1e-3 && (t.pixel.y - (y as f32 + 0.5)).abs() < 1e-3,
                                "({x}, {y}) at full resolution crosses the render at {:?}",
                                t.pixel
                            );
                        }
                        // An empty anchor (NaN or the cleared value) has no
                        // surface: ENVIRONMENT.
                        let dz = rnd.depth_at(t.texel_x, t.texel_y);
                        let empty = dz.is_nan()
                            || match rconv {
                                0 => dz >= sc.z_far,
                                1 => dz >= 1.0,
                                _ => dz <= 0.0,
                            };
                        if empty {
                            assert_eq!(t.status, ENVIRONMENT, "({x}, {y}) anchor depth {dz} is empty but {}", t.status);
                        }
                        if t.status == HIT {
                            want.hits += 1;
                            assert!(t.t.is_finite() && t.t >= 0.0, "({x}, {y}) hit t {}; anchor depth {dz}", t.t);
                        } else {
                            want.environment += 1;
                            assert_eq!(t.t, 0.0, "({x}, {y}) environment with t {}", t.t);
                            env_pixels.push((x, y));
                        }
                    }
                    _ => {
                        assert!(
                            t.pixel.x == 0.0 && t.pixel.y == 0.0 && t.texel_x == 0 && t.texel_y == 0 && t.t == 0.0,
                            "({x}, {y}) status {} with fields {t:?}",
                            t.status
                        );
                    }
                }
            }
        }
        want.host_rays = want.environment;
        want.host_rays_written = want.host_rays.min(host_len as u32);
        assert_eq!(stats, want, "resolve stats vs texels");
        // Color: black unless HIT; at full resolution the render's texel;
        // else within the range of the render colors around the anchor.
        if want_color {
            for k in 0..col_len {
                let (x, y) = ((k % ocs.max(1) as usize) as u32, (k / ocs.max(1) as usize) as u32);
                if x >= w || y >= h || y < rows.begin || y >= rows.end {
                    assert!(col.is_sentinel(k), "color texel {k} ({x}, {y}) outside rows {rows:?} written");
                    continue;
                }
                let cv = col.get(k);
                let t = out.get((y * w + x) as usize);
                if t.status != HIT {
                    assert!(bits3(cv) == [0; 3], "color ({x}, {y}) {cv:?} for status {}", t.status);
                    continue;
                }
                if o.scale == 1 {
                    let rc = rnd.color_at(t.texel_x, t.texel_y);
                    assert!(bits3(cv) == bits3(rc), "color ({x}, {y}) {cv:?} is not the render's texel {rc:?}");
                    continue;
                }
                let (mut lo, mut hi, mut finite) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3], true);
                for j in t.texel_y.saturating_sub(1)..(t.texel_y + 2).min(rh) {
                    for i in t.texel_x.saturating_sub(1)..(t.texel_x + 2).min(rw) {
                        let rc = rnd.color_at(i, j);
                        finite &= finite3(rc);
                        for (a, v) in [rc.x, rc.y, rc.z].into_iter().enumerate() {
                            lo[a] = lo[a].min(v);
                            hi[a] = hi[a].max(v);
                        }
                    }
                }
                if finite {
                    for (a, v) in [cv.x, cv.y, cv.z].into_iter().enumerate() {
                        let slack = 1e-5 * lo[a].abs().max(hi[a].abs());
                        assert!(
                            v >= lo[a] - slack && v <= hi[a] + slack,
                            "color ({x}, {y}) {cv:?} outside the render's [{lo:?}, {hi:?}] around texel ({}, {})",
                            t.texel_x,
                            t.texel_y
                        );
                    }
                }
            }
        }
        // The host list: the ENVIRONMENT pixels in row-major order.
        for k in 0..host_len {
            if k >= stats.host_rays_written as usize {
                assert!(host.is_sentinel(k), "host entry {k} past the written ones");
                continue;
            }
            let r = host.get(k);
            assert_eq!((r.x, r.y), env_pixels[k], "host ray {k} is not the {k}-th environment pixel");
            assert_eq!(r.status, ENVIRONMENT, "host ray status {}", r.status);
            assert!(r.t_min == 0.0 && r.t_max == f32::INFINITY, "host ray range [{}, {}]", r.t_min, r.t_max);
            assert!(finite3(r.origin), "host ray origin {:?}", r.origin);
            assert!((len3(r.dir) - 1.0).abs() < 1e-3, "host ray dir {:?}", r.dir);
            if moderate {
                // The origin is the pixel's point on the mirror; the direction
                // the primary ray reflected about the plane.
                let px = refl_vec2 { x: r.x as f32 + 0.5, y: r.y as f32 + 0.5 };
                let mut p = refl_vec3::default();
                // SAFETY: pointers valid.
                if unsafe { refl_camera_unproject(&mut p, &cam, px, img.texel(r.x, r.y), conv) } == refl_status::Ok && max_abs3(p) < 1e4 {
                    let e = eye.map_or(0.0, max_abs3);
                    let tol = 1e-4 * (1.0 + e + max_abs3(p));
                    assert!(
                        (p.x - r.origin.x).abs() <= tol && (p.y - r.origin.y).abs() <= tol && (p.z - r.origin.z).abs() <= tol,
                        "host ray origin {:?} is not the pixel's point {p:?}",
                        r.origin
                    );
                }
                let mut pr = refl_ray::default();
                // SAFETY: pointers valid.
                if unsafe { refl_camera_primary_ray(&mut pr, &cam, px) } == refl_status::Ok {
                    let dd = d3(pr.dir);
                    let dn = dd[0] * un[0] + dd[1] * un[1] + dd[2] * un[2];
                    let refl = [0, 1, 2].map(|a| dd[a] - 2.0 * dn * un[a]);
                    let got = d3(r.dir);
                    for a in 0..3 {
                        assert!((got[a] - refl[a]).abs() < 2e-3, "host ray dir {:?} is not the reflected {refl:?}", r.dir);
                    }
                }
            }
        }

        // 4. Bands: the same bytes as one call over the whole image.
        if (b.is_empty() || b.chance(96)) && n <= 48 * 48 && h >= 2 {
            let whole = refl_row_range { begin: 0, end: h };
            let k = 1 + b.below(h - 1);
            let (top, bot) = (refl_row_range { begin: 0, end: k }, refl_row_range { begin: k, end: h });
            let split = (k * w) as usize;
            let (c1, cst1, cb1) = cover(&g, &mirror, &o, whole);
            let (c2, cst2, cb2) = cover(&g, &mirror, &o, top);
            let (c3, cst3, cb3) = cover(&g, &mirror, &o, bot);
            assert!(c1 == refl_status::Ok && c2 == refl_status::Ok && c3 == refl_status::Ok, "cover bands refused");
            assert!(cb1[..split] == cb2[..split] && cb1[split..] == cb3[split..], "coverage differs between one call and two bands");
            assert!(cb2[split..].iter().all(|&v| v == SENTINEL) && cb3[..split].iter().all(|&v| v == SENTINEL), "a band wrote another's rows");
            assert_eq!(cst1.covered, cst2.covered + cst3.covered);
            assert_eq!(cst1.rect, rect_union(cst2.rect, cst3.rect), "band rects do not merge to the whole");
            let wc = !rnd.color.is_null();
            let (s1, st1, t1, k1, h1) = resolve(&g, &mirror, &o, &rdesc, wc, n, whole);
            let (s2, st2, t2, k2, h2) = resolve(&g, &mirror, &o, &rdesc, wc, n, top);
            let (s3, st3, t3, k3, h3) = resolve(&g, &mirror, &o, &rdesc, wc, n, bot);
            assert!(s1 == refl_status::Ok && s2 == refl_status::Ok && s3 == refl_status::Ok, "resolve bands refused: {s1:?} {s2:?} {s3:?}: {}", last_error());
            for i in 0..n {
                let (p, q) = if i < split { (&t2[i], &k2) } else { (&t3[i], &k3) };
                assert!(same_texel(&t1[i], p), "texel {i} differs between one call and two bands");
                if wc {
                    assert!(bits3(k1[i]) == bits3(q[i]), "color {i} differs between one call and two bands");
                }
            }
            assert_eq!((st1.covered, st1.hits, st1.environment, st1.host_rays), (st2.covered + st3.covered, st2.hits + st3.hits, st2.environment + st3.environment, st2.host_rays + st3.host_rays));
            assert_eq!(st1.rect, rect_union(st2.rect, st3.rect));
            let joined: Vec<_> = h2[..st2.host_rays_written as usize].iter().chain(&h3[..st3.host_rays_written as usize]).collect();
            assert_eq!(joined.len(), st1.host_rays_written as usize);
            for (a, c) in h1.iter().zip(joined) {
                assert!(same_host(a, c), "host list differs between one call and two bands");
            }
        }

        // 5. A render of another size than the setup camera's is refused
        // (e.g. one rendered for another scale or camera).
        if (b.is_empty() || b.chance(64)) && rw < MAX_SIDE * 2 {
            let (ew, eh) = if b.bool() { (rw + 1, rh) } else { (rw, rh + 1) };
            {
                let buf = Buf::from_fn(n_of(ew, eh), PtrKind::Valid, |_| 0.5f32);
                let r2 = refl_planar_render {
                    depth: img_f32(&buf, ew, eh, ew),
                    color: refl_image_vec3 { data: core::ptr::null(), len: 0, width: 0, height: 0, stride: 0 },
                };
                let (s, ..) = resolve(&g, &mirror, &o, &r2, false, 0, refl_row_range { begin: 0, end: h });
                assert_eq!(s, refl_status::InvalidArgument, "a {ew}x{eh} render accepted for a {rw}x{rh} setup camera");
            }
        }
    }
});

fn rows_ok_for(rows: refl_row_range, h: u32) -> bool {
    rows.begin < rows.end && rows.end <= h
}
