//! The cluster pass (seed 003's second-order reflections as one plan call
//! per frame and one finalize call per cluster and row band):
//! `refl_cluster_pass_options_default`, `refl_cluster_plan_len`,
//! `refl_cluster_plan`, `refl_cluster_finalize_rows`.
//!
//! A fuzzed G-buffer (`FuzzGBuffer`: depth with its camera and convention,
//! normals in either space, optional mask, roughness, lit color and
//! back-face depth, each sometimes of the wrong size, short, NULL or
//! misaligned), an object-id image (sometimes of another size, short, NULL
//! or misaligned; ids past the objects, `UINT32_MAX`), a few lobes (mirror,
//! glossy, invalid), fuzzed options (in and out of range), plan buffers of
//! the queried, shorter and longer lengths, renders through the planned
//! cluster cameras (the floor/wall/box scene of `depth_values`, any
//! convention, optional back faces; sometimes of another camera or size),
//! row bands, host lists, outputs aliasing inputs or each other, tampered
//! entries.
//!
//! Checked: the defaults are the documented values; the NULL and error
//! rules (nothing written on error, inputs never written; a NULL checked
//! late is reported unless another argument is bad: the same call with the
//! pointer valid fails too); accepted options, lobes, images and lengths
//! lie in their documented ranges; the size query's formula; on a plan:
//! the entries (increasing ids below the bins, objects and lobes of their
//! pixels, pixel lists in raster order in the scratch with their cluster
//! ids, exact row spans, fallback reasons in range with zero fields,
//! `TOO_FEW_PIXELS` exactly below `min_pixels`, cameras valid within
//! `max_resolution`, `f` within its guards, unit normals toward the eye,
//! frusta holding the camera's view), the stats, nothing written past the
//! entries or the scratch; on a finalize: only the cluster's pixels of the
//! band written, statuses in range and consistent with their shades (rays,
//! hits, weights, unit directions, colors within the render's), fallback
//! clusters all `NO_PROJECTION`, the stats, the host list (raster order,
//! statuses, surface origins, mirror directions, t_min/t_max), the shades
//! bit for bit `refl_cluster_finalize`'s; two bands give the same bytes as
//! one call; a render of another camera and a G-buffer without the
//! entry's rows are refused.
#![no_main]

use core::mem::size_of;
use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

const NONE: u32 = u32::MAX;
const HIT: u32 = 2;
const SKY: u32 = 3;
const LEFT_IMAGE: u32 = 4;
const NO_PROJECTION: u32 = 7;
const FB_TOO_FEW: u32 = 1;
const FB_LAST: u32 = 5;
/// Largest cluster render (texels) the target draws.
const MAX_RENDER: u32 = 32 * 32;

/// True with probability about `k / 256`, false for the zeros past the
/// input's end (so a short input takes the valid paths).
fn rare(b: &mut Bytes, k: u8) -> bool {
    b.u8() > 255 - k
}

/// A valid pointer, or with probability about `k / 256` a fuzzed kind.
fn kind(b: &mut Bytes, k: u8) -> PtrKind {
    if rare(b, k) {
        b.ptr_kind()
    } else {
        PtrKind::Valid
    }
}

/// `need`, or with probability about 40 / 256 a fuzzed length around it.
fn len_ok(b: &mut Bytes, need: usize) -> usize {
    if rare(b, 40) {
        b.len_for(need)
    } else {
        need
    }
}

/// Whether texels `from..` of `b` all still hold the sentinel (one
/// comparison, cheap under the coverage instrumentation).
fn all_sentinel<T: Copy>(b: &Buf<T>, from: usize) -> bool {
    let bytes = b.bytes();
    let from = (from * size_of::<T>()).min(bytes.len());
    bytes[from..] == vec![SENTINEL; bytes.len() - from][..]
}

/// Per texel of `b`: whether it still holds the sentinel.
fn sentinel_mask<T: Copy>(b: &Buf<T>) -> Vec<bool> {
    let pat = vec![SENTINEL; size_of::<T>()];
    b.bytes().chunks_exact(size_of::<T>()).map(|c| c == &pat[..]).collect()
}

/// Whether a non-NULL pointer is misaligned for its type.
fn misal<T>(p: *mut T) -> bool {
    !p.is_null() && (p as usize) % core::mem::align_of::<T>() != 0
}


fn options(b: &mut Bytes) -> refl_cluster_pass_options {
    let mut o = refl_cluster_pass_options_default();
    // Small cluster cameras: the target renders through them.
    o.camera.max_resolution = b.pick(&[4, 8, 12, 16, 24, 32]);
    o.camera.far_distance = if rare(b, 12) { b.f32_special() } else { b.f32_fine(1.0, 60.0) };
    if rare(b, 40) {
        match b.u8() % 3 {
            0 => o.cluster.max_theta_bins = b.pick(&[0, 1, 2, 3, 13, 64, 1024, 1025, u32::MAX]),
            1 => o.cluster.max_phi_bins = b.pick(&[0, 1, 2, 8, 1024, 1025]),
            _ => o.cluster.gain = b.f32_in(0.01, 512.0),
        }
    }
    if rare(b, 48) {
        match b.u8() % 8 {
            6 => o.camera.glossy_blur_radius = if b.bool() { b.f32_special() } else { b.f32_in(-1.0, 20.0) },
            0 => o.camera.cone_half_angle = b.f32_in(-0.1, 1.6),
            1 => o.camera.resolution_scale = b.f32_in(0.05, 4.0),
            2 => o.camera.max_resolution = b.pick(&[0, 1, 2, 2048, u32::MAX]),
            3 => o.camera.min_pixels = b.pick(&[0, 1, 2, 3, 8, 64, u32::MAX]),
            4 => o.camera.max_f = b.f32_in(0.5, 32.0),
            5 => o.camera.far_distance = b.f32_in(-1.0, 1e4),
            _ => o.camera.min_pixels = 2,
        }
    }
    if rare(b, 64) {
        o.thickness = match b.u8() % 4 {
            0 => f32::INFINITY,
            1 => b.f32_special(),
            _ => b.f32_fine(0.0, 0.1),
        };
    }
    if rare(b, 48) {
        o.step.stride = b.pick(&[0, 1, 1, 2, 3, 8]);
        o.step.max_steps = b.pick(&[0, 1, 2, 16, 256, u32::MAX]);
    }
    if rare(b, 64) {
        o.refine = b.bool();
        o.fade = b.bool();
        o.seed = b.u32();
    }
    if rare(b, 40) {
        o.t_min = b.f32_in(0.0, 2.0);
    }
    if rare(b, 16) {
        o.glossy_single_ray = b.bool();
    }
    if rare(b, 40) {
        o.t_max = t_max(b);
    }
    o
}

fn cluster_options_ok(c: &refl_cluster_options) -> bool {
    (1..=1024).contains(&c.max_theta_bins) && (1..=1024).contains(&c.max_phi_bins) && c.gain.is_finite() && c.gain > 0.0
}

/// Every option in its documented range (header, `refl_cluster_pass_options`
/// and the structs it holds).
fn options_in_range(o: &refl_cluster_pass_options) -> bool {
    let c = &o.camera;
    cluster_options_ok(&o.cluster)
        && c.far_distance.is_finite()
        && c.far_distance > 0.0
        && c.cone_half_angle >= 0.0
        && c.cone_half_angle < 1.5
        && c.resolution_scale.is_finite()
        && c.resolution_scale > 0.0
        && c.max_resolution > 0
        && c.min_pixels >= 2
        && c.max_f.is_finite()
        && c.max_f >= 1.0
        && c.glossy_blur_radius > 0.0
        && o.thickness >= 0.0
        && o.step.stride >= 1
        && o.t_min.is_finite()
        && o.t_min >= 0.0
        && o.t_max > o.t_min
}

fn lobe(b: &mut Bytes, small: bool) -> refl_cluster_lobe {
    match b.u8() {
        244.. => refl_cluster_lobe { rays: b.pick(&[0, 65, u32::MAX, 2, 1]), exponent: b.f32_special(), max_angle: b.f32_in(-0.5, 2.0) },
        160..=243 => refl_cluster_lobe {
            rays: if rare(b, 8) { if small { 64 } else { 16 } } else { 2 + b.below(7) },
            exponent: b.f32_in(0.0, 200.0),
            max_angle: b.f32_in(0.02, 1.45),
        },
        _ => refl_cluster_lobe { rays: 1, exponent: 0.0, max_angle: 0.0 },
    }
}

fn lobe_valid(l: &refl_cluster_lobe) -> bool {
    (1..=64).contains(&l.rays) && (l.rays == 1 || (l.exponent.is_finite() && l.exponent >= 0.0 && l.max_angle > 0.0 && l.max_angle < 1.5))
}

fn same_lobe(a: &refl_cluster_lobe, b: &refl_cluster_lobe) -> bool {
    a.rays == b.rays && a.exponent.to_bits() == b.exponent.to_bits() && a.max_angle.to_bits() == b.max_angle.to_bits()
}

fn hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// The object id of pixel (x, y) of an id image `iw` wide.
fn id_at(mode: u8, seed: u8, x: u32, y: u32, iw: u32, nobj: u32) -> u32 {
    let k = nobj.max(1);
    let hole = (x.wrapping_mul(7) ^ y.wrapping_mul(3)).wrapping_add(u32::from(seed)) % 13 == 0;
    match mode % 8 {
        0..=2 => {
            if hole && mode & 0x10 != 0 {
                NONE
            } else {
                (x * k / iw.max(1)).min(k - 1)
            }
        }
        3 => 0,
        4 => match hash(x ^ (y << 8) ^ (u32::from(seed) << 16)) % (nobj + 3) {
            v if v == nobj + 2 => u32::MAX - 1,
            v => v,
        },
        5 => y % k,
        6 => {
            if hole {
                nobj
            } else {
                0
            }
        }
        _ => NONE,
    }
}

fn same_shade(a: &refl_cluster_shade, b: &refl_cluster_shade) -> bool {
    bits3(a.rgb) == bits3(b.rgb)
        && a.hit_weight.to_bits() == b.hit_weight.to_bits()
        && a.env_weight.to_bits() == b.env_weight.to_bits()
        && bits3(a.env_dir) == bits3(b.env_dir)
        && bits3(a.mirror_dir) == bits3(b.mirror_dir)
        && (a.rays, a.hits, a.fetches, a.steps, a.self_hits) == (b.rays, b.hits, b.fetches, b.steps, b.self_hits)
}

fn same_texel(a: &refl_cluster_texel, b: &refl_cluster_texel) -> bool {
    a.status == b.status && same_shade(&a.shade, &b.shade)
}

fn same_stats(a: &refl_cluster_stats, b: &refl_cluster_stats) -> bool {
    (a.pixels, a.hits, a.sky, a.host_rays, a.host_rays_written, a.rays, a.ray_hits, a.self_hits)
        == (b.pixels, b.hits, b.sky, b.host_rays, b.host_rays_written, b.rays, b.ray_hits, b.self_hits)
}

fn img_ok<T: Copy>(buf: &Buf<T>, iw: u32, ih: u32, stride: u32, w: u32, h: u32) -> bool {
    buf.usable() && iw == w && ih == h && required_len(iw, ih, stride).is_some_and(|n| buf.len() >= n)
}

/// Whether refl must accept the G-buffer (every documented requirement).
fn gbuffer_valid(fg: &FuzzGBuffer) -> bool {
    let (w, h) = (fg.img.width, fg.img.height);
    let opt = |present: bool, ok: bool| !present || ok;
    fg.img.valid()
        && fg.normal_space <= 1
        && img_ok(&fg.normals.0, fg.normals.1, fg.normals.2, fg.normals.3, w, h)
        && opt(!fg.mask.0.is_null(), img_ok(&fg.mask.0, fg.mask.1, fg.mask.2, fg.mask.3, w, h))
        && opt(!fg.roughness.0.is_null(), img_ok(&fg.roughness.0, fg.roughness.1, fg.roughness.2, fg.roughness.3, w, h))
        && opt(fg.has_color(), img_ok(&fg.color.0, fg.color.1, fg.color.2, fg.color.3, w, h))
        && opt(!fg.back.0.is_null(), img_ok(&fg.back.0, fg.back.1, fg.back.2, fg.back.3, w, h))
}

/// The header's `refl_cluster_camera` of a fallback: every field but the
/// reason 0.
fn fallback_fields_zero(c: &refl_cluster_camera) -> bool {
    let z = |v: f32| v.to_bits() == 0;
    c.camera.view.m.iter().all(|&v| z(v))
        && z(c.camera.fov_y)
        && z(c.camera.z_near)
        && z(c.camera.z_far)
        && c.camera.width == 0
        && c.camera.height == 0
        && bits3(c.clip.normal) == [0; 3]
        && z(c.clip.d)
        && bits3(c.centroid) == [0; 3]
        && bits3(c.normal) == [0; 3]
        && bits3(c.eye0) == [0; 3]
        && z(c.f)
        && c.diagonals.iter().all(|&v| z(v))
        && !c.planar
        && z(c.far_distance)
        && c.pixels_used == 0
}

/// A host render of a cluster through `cam`: the `depth_values` scene in a
/// fuzzed convention, colors in [0, 1], optional back faces; sometimes a
/// short or misaligned depth, a color or back-face image of another size.
struct Render {
    depth: Buf<f32>,
    color: Buf<refl_vec3>,
    back: Buf<f32>,
    desc: refl_cluster_render,
    snaps: [Vec<u8>; 3],
    /// Every documented requirement holds (for this camera).
    valid: bool,
}

impl Render {
    fn new(b: &mut Bytes, cam: &refl_camera) -> Self {
        let (cw, ch) = (cam.width, cam.height);
        let n = cw as usize * ch as usize;
        let conv = if rare(b, 16) { b.convention() } else { u32::from(b.u8()) % 3 };
        let dv = depth_values(b, cam, conv.min(2), cw, ch);
        let (dlen, dkind) = if rare(b, 8) { (b.len_for(n), b.ptr_kind()) } else { (n, PtrKind::Valid) };
        let depth = Buf::from_fn(dlen, dkind, |i| dv.get(i).copied().unwrap_or(f32::NAN));
        let (colw, colh) = if rare(b, 8) { (cw + 1 - 2 * u32::from(cw > 1 && b.bool()), ch) } else { (cw, ch) };
        let ckind = kind(b, 8);
        let color = Buf::from_fn(colw as usize * colh as usize, ckind, |i| {
            let (x, y) = ((i % colw as usize) as f32, (i / colw as usize) as f32);
            v3(x / colw as f32, y / colh as f32, 0.25)
        });
        let with_back = rare(b, 48);
        let (bw, bh) = if with_back && rare(b, 16) { (cw, ch + 1) } else { (cw, ch) };
        let push = b.f32_fine(0.0, 0.5);
        let back = if with_back {
            Buf::from_fn(bw as usize * bh as usize, if rare(b, 8) { PtrKind::Misaligned } else { PtrKind::Valid }, |i| {
                let d = dv.get(i).copied().unwrap_or(f32::NAN);
                if conv == 0 { d * (1.0 + push) } else { d }
            })
        } else {
            Buf::sentinel(0, PtrKind::Null)
        };
        let desc = refl_cluster_render {
            depth: refl_depth_image { depth: img_f32(&depth, cw, ch, cw), camera: *cam, convention: conv },
            color: refl_image_vec3 { data: color.cptr(), len: color.len(), width: colw, height: colh, stride: colw },
            back_depth: img_f32(&back, bw, bh, bw),
            // No reflector images: `second_intersection` stays off here.
            reflector_diffuse: refl_image_vec3 { data: core::ptr::null(), len: 0, width: 0, height: 0, stride: 0 },
            reflector_ids: refl_image_u32 { data: core::ptr::null(), len: 0, width: 0, height: 0, stride: 0 },
        };
        let valid = conv <= 2
            && depth.usable()
            && dlen >= n
            && color.usable()
            && (colw, colh) == (cw, ch)
            && (!with_back || (back.usable() && (bw, bh) == (cw, ch)));
        let snaps = [depth.snapshot(), color.snapshot(), back.snapshot()];
        Self { depth, color, back, desc, snaps, valid }
    }

    #[track_caller]
    fn assert_unchanged(&self, what: &str) {
        self.depth.assert_unchanged(&self.snaps[0], what);
        self.color.assert_unchanged(&self.snaps[1], what);
        self.back.assert_unchanged(&self.snaps[2], what);
    }
}

/// Everything a finalize call shares.
struct Ctx<'a> {
    fg: &'a FuzzGBuffer,
    g: refl_gbuffer,
    o: refl_cluster_pass_options,
    scratch: &'a Buf<u32>,
    slen: usize,
    w: u32,
    h: u32,
    n: usize,
    eye: Option<refl_vec3>,
}

struct Fin {
    s: refl_status,
    st: refl_cluster_stats,
    texels: Vec<refl_cluster_texel>,
    host: Vec<refl_host_ray>,
    written: Vec<bool>,
}

/// One `refl_cluster_finalize_rows` into fresh valid buffers.
fn run(
    c: &Ctx,
    g: &refl_gbuffer,
    e: &refl_cluster_plan_entry,
    r: Option<&refl_cluster_render>,
    rows: refl_row_range,
    host_len: usize,
) -> Fin {
    let n = c.n.max(g.depth.camera.width as usize * g.depth.camera.height as usize);
    let mut out = Buf::<refl_cluster_texel>::sentinel(n, PtrKind::Valid);
    let mut host = Buf::<refl_host_ray>::sentinel(host_len, if host_len > 0 { PtrKind::Valid } else { PtrKind::Null });
    let mut st = refl_cluster_stats::default();
    let rp = r.map_or(core::ptr::null(), |r| r as *const _);
    // SAFETY: buffers valid for their lengths; the G-buffer's images as
    // fuzzed (already accepted); the render's buffers alive.
    let s = unsafe {
        refl_cluster_finalize_rows(&mut st, out.ptr(), n, host.ptr(), host_len, g, &c.o, c.scratch.cptr(), c.slen, e, rp, rows)
    };
    no_panic(s, "refl_cluster_finalize_rows");
    let written = sentinel_mask(&out).iter().map(|&u| !u).collect();
    let texels = (0..n).map(|i| out.get(i)).collect();
    let host = (0..host_len).map(|i| if host.is_sentinel(i) { refl_host_ray::default() } else { host.get(i) }).collect();
    Fin { s, st, texels, host, written }
}

/// The G-buffer's normal of a pixel as the pass reads it (world space):
/// normalized in f32 as refl-core does, `n * (1 / sqrt(|n|^2))`.
fn world_normal(n: refl_vec3) -> Option<refl_vec3> {
    let len2 = n.x * n.x + n.y * n.y + n.z * n.z;
    if !(len2 > 0.0 && len2.is_finite()) {
        return None;
    }
    let k = 1.0 / len2.sqrt();
    Some(v3(n.x * k, n.y * k, n.z * k))
}

/// `refl_cluster_finalize_rows` of the accepted call (`first`: its texels)
/// again with `second_intersection` and reflector images (fuzzed ids near
/// the entry's object, diffuse colors, sometimes missing or of another
/// size). A convex entry is finalized as before, bit for bit; a concave
/// one needs both images of the G-buffer's size (else INVALID_ARGUMENT,
/// nothing written), and then every pixel none of whose rays met its
/// reflector is as before, and the others count their self hits within
/// their hits.
fn second_intersection(
    b: &mut Bytes,
    c: &Ctx,
    e: &refl_cluster_plan_entry,
    mut r: refl_cluster_render,
    rows: refl_row_range,
    first: &Buf<refl_cluster_texel>,
) {
    let (w, h, n) = (c.w, c.h, c.n);
    let ids: Vec<u32> = (0..n)
        .map(|_| match b.u8() % 4 {
            3 => b.u32(),
            _ => e.object,
        })
        .collect();
    let diffuse: Vec<refl_vec3> = (0..n).map(|i| v3((i % 7) as f32 * 0.1, b.f32_in(0.0, 1.0), 0.5)).collect();
    // Zeros past the input's end take the valid path.
    let (dw, iw) = match b.u8() % 8 {
        6 => (w, w.saturating_sub(1)),
        7 => (w.saturating_sub(1), w),
        _ => (w, w),
    };
    let missing = rare(b, 64);
    if !missing {
        let dh = if dw == w { h } else { (n as u32 / dw.max(1)).min(h) };
        let ih = if iw == w { h } else { (n as u32 / iw.max(1)).min(h) };
        r.reflector_diffuse = refl_image_vec3 { data: diffuse.as_ptr(), len: n, width: dw, height: dh, stride: dw.max(1) };
        r.reflector_ids = refl_image_u32 { data: ids.as_ptr(), len: n, width: iw, height: ih, stride: iw.max(1) };
    }
    let sized = !missing && (dw, iw) == (w, w);
    let o2 = refl_cluster_pass_options { second_intersection: true, ..c.o };
    let mut out = Buf::<refl_cluster_texel>::sentinel(n, PtrKind::Valid);
    let mut st = refl_cluster_stats::default();
    // SAFETY: every buffer valid for its length.
    let s = unsafe {
        refl_cluster_finalize_rows(&mut st, out.ptr(), n, core::ptr::null_mut(), 0, &c.g, &o2, c.scratch.cptr(), c.slen, e, &r, rows)
    };
    let what = "refl_cluster_finalize_rows (second intersection)";
    no_panic(s, what);
    if e.camera.concave && !sized {
        // Missing images, or of another size: refused.
        assert!(s != refl_status::Ok, "{what}: a concave entry accepted without its reflector images");
        assert!(all_sentinel(&out, 0), "{what}: wrote on error");
        return;
    }
    if !e.camera.concave && !sized && !missing {
        // A view of another size is still a valid image; a convex entry
        // does not read it.
        if s != refl_status::Ok {
            return;
        }
    }
    assert_eq!(s, refl_status::Ok, "{what}: {}", last_error());
    let was = sentinel_mask(first);
    let now = sentinel_mask(&out);
    let mut self_hits = 0u64;
    for i in 0..n {
        assert_eq!(was[i], now[i], "{what}: texel {i} written in one call only");
        if now[i] {
            continue;
        }
        let (a, t) = (first.get(i), out.get(i));
        self_hits += u64::from(t.shade.self_hits);
        if t.shade.self_hits == 0 {
            assert!(same_texel(&a, &t), "{what}: texel {i} changed without a self hit: {a:?} vs {t:?}");
        } else {
            assert!(e.camera.concave, "{what}: a self hit in a convex cluster");
            assert!(t.shade.self_hits <= t.shade.hits && t.shade.hits <= t.shade.rays, "{what}: {t:?}");
            assert!(bits3(t.shade.mirror_dir) == bits3(a.shade.mirror_dir), "{what}: mirror direction changed");
            // A self hit replaces a depth-image hit or a miss: never fewer
            // hits, never more fallback (the colors are the host's, any
            // value).
            assert!(t.shade.hits >= a.shade.hits && t.shade.env_weight <= a.shade.env_weight, "{what}: {a:?} -> {t:?}");
            // The same rays through the depth image (the self test is not
            // counted there).
            assert_eq!((t.shade.rays, t.shade.fetches, t.shade.steps), (a.shade.rays, a.shade.fetches, a.shade.steps), "{what}");
        }
    }
    assert_eq!(st.self_hits, self_hits, "{what}: stats");
}

/// Finalizes entry `e` of the plan with fuzzed arguments and checks the
/// result.
fn finalize(b: &mut Bytes, c: &Ctx, e0: &refl_cluster_plan_entry, gb: &Buf<refl_gbuffer>, ob: &Buf<refl_cluster_pass_options>) {
    let (w, h, n) = (c.w, c.h, c.n);
    let o = &c.o;
    let has_cam = e0.camera.fallback == 0;
    let cam = e0.camera.camera;
    let small = u64::from(cam.width) * u64::from(cam.height) <= u64::from(MAX_RENDER);
    // The render: through the entry's camera (or NULL for a fallback).
    let render = if has_cam && small {
        Some(Render::new(b, &cam))
    } else if !has_cam && c.n <= MAX_RENDER as usize && rare(b, 24) {
        Some(Render::new(b, &c.g.depth.camera))
    } else {
        None
    };
    // A tampered entry: 1..=5 must be refused; 6 (a camera entry marked
    // as a fallback) is a valid fallback entry.
    let tamper = if rare(b, 24) { 1 + b.below(6) } else { 0 };
    let mut e = *e0;
    match tamper {
        1 => e.rows.end = h + 1 + b.below(3),
        2 => e.first = (n as u32).saturating_sub(e.len) + 1 + b.below(4),
        3 => e.camera.fallback = b.pick(&[6, 7, 0x100, u32::MAX]),
        4 => e.lobe = refl_cluster_lobe { rays: b.pick(&[0, 65, u32::MAX]), exponent: 1.0, max_angle: 0.5 },
        5 if !has_cam => e.camera.fallback = 0,
        5 => e.camera.camera.width = 0,
        6 if has_cam => e.camera.fallback = 2,
        _ => {}
    }
    let refused = (1..=5).contains(&tamper);
    let is_cam = e.camera.fallback == 0;

    // The entry's pixels.
    let px: Vec<u32> = (0..e0.len as usize).map(|k| c.scratch.get(n + e0.first as usize + k)).collect();

    let rows = match b.u8() % 4 {
        2 => b.rows(h),
        3 => {
            let span = e0.rows.end - e0.rows.begin;
            let a = e0.rows.begin + b.below(span);
            refl_row_range { begin: a, end: a + 1 + b.below(e0.rows.end - a) }
        }
        _ => e0.rows,
    };
    let alias = if rare(b, 12) { 1 + b.below(3) } else { 0 };
    let out_len = len_ok(b, n);
    let mut out = Buf::<refl_cluster_texel>::sentinel(out_len, kind(b, 24));
    let host_len = match b.u8() % 4 {
        2 => 0,
        3 => b.below(4) as usize,
        _ => e0.len as usize,
    };
    let mut host = Buf::<refl_host_ray>::sentinel(host_len, if host_len == 0 && b.bool() { PtrKind::Null } else { kind(b, 24) });
    let mut fst = out1::<refl_cluster_stats>(kind(b, 24));
    let sc_len = if rare(b, 8) { b.below(2 * n as u32 + 1) as usize } else { c.slen };
    let eb = Buf::from_slice(&[e], kind(b, 16));
    let rkind = kind(b, 16);
    let rb = render.as_ref().map(|r| Buf::from_slice(&[r.desc], rkind));
    let rp = rb.as_ref().map_or(core::ptr::null(), |r| r.cptr());
    let (mut op, mut ol, mut hp, mut hl) = (out.ptr(), out_len, host.ptr(), host_len);
    let mut alias_on = false;
    match alias {
        // `out` over the scratch (an input).
        1 if c.scratch.usable() && c.slen * 4 >= size_of::<refl_cluster_texel>() => {
            op = c.scratch.cptr().cast_mut().cast();
            ol = c.slen * 4 / size_of::<refl_cluster_texel>();
            alias_on = true;
        }
        // `host` over `out`.
        2 if out.usable() && out_len > 0 => {
            hp = op.cast();
            hl = out_len * size_of::<refl_cluster_texel>() / size_of::<refl_host_ray>();
            alias_on = hl > 0;
        }
        // `out` over the G-buffer's normals (an input).
        3 if c.fg.normals.0.usable() && c.fg.normals.0.len() * 12 >= size_of::<refl_cluster_texel>() => {
            op = c.fg.normals.0.cptr().cast_mut().cast();
            ol = c.fg.normals.0.len() * 12 / size_of::<refl_cluster_texel>();
            alias_on = true;
        }
        _ => {}
    }
    let scratch_snap = c.scratch.snapshot();
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe {
        refl_cluster_finalize_rows(fst.ptr(), op, ol, hp, hl, gb.cptr(), ob.cptr(), c.scratch.cptr(), sc_len, eb.cptr(), rp, rows)
    };
    let what = "refl_cluster_finalize_rows";
    let req_null = fst.is_null() || op.is_null() || (hp.is_null() && hl > 0) || gb.is_null() || ob.is_null();
    let late_null = eb.is_null() || (is_cam && rb.as_ref().is_none_or(|r| r.is_null()));
    let render_null = rb.as_ref().is_some_and(|r| r.is_null());
    let render_img_null = rb.is_some() && render.as_ref().is_some_and(|r| r.depth.is_null() || r.color.is_null());
    let any_null = req_null || late_null || render_null || render_img_null || hp.is_null();
    let mis = misal(op) || misal(hp) || [fst.kind(), eb.kind(), rkind].contains(&PtrKind::Misaligned);
    null_rules_m(s, req_null, any_null, mis, what);
    on_error_untouched(
        s,
        &[
            ("out_stats", fst.is_sentinel(0)),
            ("out", all_sentinel(&out, 0)),
            ("host", all_sentinel(&host, 0)),
        ],
        what,
    );
    c.fg.assert_unchanged(what);
    c.scratch.assert_unchanged(&scratch_snap, "refl_cluster_finalize_rows scratch");
    if let Some(r) = &render {
        r.assert_unchanged("refl_cluster_finalize_rows render");
    }
    if alias_on || refused {
        assert!(s != refl_status::Ok, "{what} accepted an aliased output ({alias}) or a tampered entry ({tamper}): {e:?}");
    }
    // A NULL `cluster` or `render` checked after the sizes: another bad
    // argument may be reported, but then the call fails with the pointer
    // valid too.
    if !req_null && late_null && s != refl_status::NullPointer && s != refl_status::Ok && !alias_on {
        let real_r = render.as_ref().map(|r| r.desc);
        if real_r.is_some() || !is_cam {
            let mut out2 = Buf::<refl_cluster_texel>::sentinel(out_len, out.kind());
            let mut host2 = Buf::<refl_host_ray>::sentinel(host_len, host.kind());
            let mut st2 = out1::<refl_cluster_stats>(fst.kind());
            let rp2 = real_r.as_ref().map_or(core::ptr::null(), |r| r as *const _);
            // SAFETY: as above, with valid `cluster` and `render`.
            let s2 = unsafe {
                refl_cluster_finalize_rows(st2.ptr(), out2.ptr(), out_len, host2.ptr(), host_len, gb.cptr(), ob.cptr(), c.scratch.cptr(), sc_len, &e, rp2, rows)
            };
            assert!(s2 != refl_status::Ok, "{what}: a NULL cluster/render reported as {s:?} though it was the only bad argument");
        }
    }
    if s != refl_status::Ok {
        return;
    }

    // Accepted: the documented requirements held.
    assert!(rows.begin <= rows.end && rows.end <= h, "{what} accepted rows {rows:?} of {h}");
    assert!(out_len >= n && sc_len >= 2 * n, "{what} accepted out_len {out_len} / scratch_len {sc_len} for {n} pixels");
    assert!(!refused && !alias_on);
    if is_cam {
        let r = render.as_ref().expect("a camera entry was accepted without a render");
        assert!(r.valid, "{what} accepted an invalid render: {:?}", r.desc);
    }
    let stats = fst.get(0);
    let inband = |p: u32| p / w >= rows.begin && p / w < rows.end;
    let band: Vec<u32> = px.iter().copied().filter(|&p| inband(p)).collect();
    let mut mine = vec![false; n];
    for &p in &band {
        mine[p as usize] = true;
    }
    let lobe_rays = e.lobe.rays;
    let (mut hits, mut sky, mut hostc, mut rays, mut ray_hits) = (0u32, 0u32, 0u32, 0u64, 0u64);
    let untouched = sentinel_mask(&out);
    for i in 0..out_len {
        if i >= n || !mine[i] {
            assert!(untouched[i], "{what} wrote texel {i}, not a pixel of the cluster in rows {rows:?}");
            continue;
        }
        let (x, y) = (i as u32 % w, i as u32 / w);
        let t = out.get(i);
        let sh = &t.shade;
        assert!((HIT..=NO_PROJECTION).contains(&t.status), "texel ({x}, {y}) status {}", t.status);
        assert!((len3(sh.mirror_dir) - 1.0).abs() < 1e-3, "mirror dir {:?}", sh.mirror_dir);
        assert!((len3(sh.env_dir) - 1.0).abs() < 1e-3, "env dir {:?} ({t:?})", sh.env_dir);
        assert!(finite3(sh.rgb) && sh.hit_weight.is_finite() && sh.env_weight.is_finite(), "shade {t:?}");
        if !is_cam {
            // A cluster without a camera: every pixel to the host, its
            // environment share 1 in the mirror direction.
            assert_eq!(t.status, NO_PROJECTION, "fallback cluster pixel ({x}, {y}): {t:?}");
            assert!(sh.env_weight == 1.0 && sh.hit_weight == 0.0 && sh.hits == 0 && bits3(sh.rgb) == [0; 3], "fallback shade {t:?}");
            assert!(bits3(sh.env_dir) == bits3(sh.mirror_dir), "fallback env dir {t:?}");
        } else {
            assert!(sh.rays >= 1 && sh.rays <= lobe_rays && sh.hits <= sh.rays, "rays {} hits {} of a lobe of {lobe_rays}: {t:?}", sh.rays, sh.hits);
            let r = f64::from(sh.rays);
            let miss_share = f64::from(sh.rays - sh.hits) / r;
            assert!((f64::from(sh.env_weight) - miss_share).abs() <= 1e-6, "env weight {} for {} of {} rays missed", sh.env_weight, sh.rays - sh.hits, sh.rays);
            let hit_share = f64::from(sh.hits) / r;
            // Only glossy clusters fade (seed 003 Sec. 3.5 item 2).
            if o.fade && lobe_rays > 1 {
                assert!(sh.hit_weight >= 0.0 && f64::from(sh.hit_weight) <= hit_share + 1e-6, "faded hit weight {} ({t:?})", sh.hit_weight);
            } else {
                assert!((f64::from(sh.hit_weight) - hit_share).abs() <= 1e-6, "hit weight {} ({t:?})", sh.hit_weight);
            }
            // Colors in [0, 1]: the weighted sum lies within [0, hit_weight].
            for v in [sh.rgb.x, sh.rgb.y, sh.rgb.z] {
                assert!(v >= 0.0 && v <= sh.hit_weight + 1e-5, "rgb {:?} with hit weight {}", sh.rgb, sh.hit_weight);
            }
            match t.status {
                HIT => assert!(sh.hits == sh.rays && sh.env_weight == 0.0, "HIT with a missed ray: {t:?}"),
                SKY => assert!(sh.env_weight > 0.0, "SKY without a missed ray: {t:?}"),
                _ => assert!(sh.hits < sh.rays, "host status {} but every ray hit: {t:?}", t.status),
            }
            if sh.env_weight == 0.0 {
                assert!(bits3(sh.env_dir) == bits3(sh.mirror_dir), "env dir of a pixel without misses: {t:?}");
            }
        }
        match t.status {
            HIT => hits += 1,
            SKY => sky += 1,
            _ => hostc += 1,
        }
        rays += u64::from(sh.rays);
        ray_hits += u64::from(sh.hits);
    }
    assert_eq!(
        (stats.pixels as usize, stats.hits, stats.sky, stats.host_rays, stats.rays, stats.ray_hits),
        (band.len(), hits, sky, hostc, rays, ray_hits),
        "stats {stats:?}"
    );
    assert_eq!(stats.host_rays_written as usize, (hostc as usize).min(host_len), "host rays written");
    // The host list: the first host pixels of the band in raster order.
    let host_px: Vec<u32> = band.iter().copied().filter(|&p| out.get(p as usize).status >= LEFT_IMAGE).collect();
    let gcam = c.g.depth.camera;
    assert!(all_sentinel(&host, stats.host_rays_written as usize), "host entries past the written ones");
    for k in 0..(stats.host_rays_written as usize).min(host_len) {
        let r = host.get(k);
        let p = host_px[k];
        assert!((r.x, r.y) == (p % w, p / w), "host ray {k} at ({}, {}), want pixel {p}", r.x, r.y);
        let t = out.get(p as usize);
        assert_eq!(r.status, t.status, "host ray status");
        assert!(bits3(r.dir) == bits3(t.shade.mirror_dir), "host ray dir {:?} vs mirror dir {:?}", r.dir, t.shade.mirror_dir);
        assert!(r.t_min.to_bits() == o.t_min.to_bits() && r.t_max.to_bits() == o.t_max.to_bits(), "host ray range");
        // The surface point: the G-buffer's depth unprojected (the first
        // 32 host rays).
        if k >= 32 {
            continue;
        }
        let mut q = refl_vec3::default();
        let d = c.fg.img.texel(r.x, r.y);
        // SAFETY: pointers valid.
        let us = unsafe { refl_camera_unproject(&mut q, &gcam, refl_vec2 { x: r.x as f32 + 0.5, y: r.y as f32 + 0.5 }, d, c.fg.img.conv) };
        assert_eq!(us, refl_status::Ok, "a cluster pixel without a surface");
        assert!(bits3(r.origin) == bits3(q), "host ray origin {:?}, surface {q:?}", r.origin);
    }

    // The shades bit for bit `refl_cluster_finalize`'s (world-space
    // normals, whose normalization and turn toward the eye the target can
    // repeat; grazing pixels left out).
    if let (true, Some(r), 0, Some(eye)) = (is_cam, render.as_ref(), c.fg.normal_space, c.eye) {
        // At most 32 of the band's pixels (any list of the cluster's
        // pixels is a valid kernel input).
        let step = band.len().div_ceil(32).max(1);
        let sub: Vec<u32> = band.iter().copied().skip(e.id as usize % step).step_by(step).collect();
        compare_kernel(c, &e, r, &sub, &out, eye);
    }

    if tamper != 0 {
        return;
    }
    let rdesc = render.as_ref().map(|r| r.desc);
    // Two bands give the same bytes as one call over the entry's rows.
    if rare(b, 64) && e.rows.end - e.rows.begin >= 2 {
        let k = e.rows.begin + 1 + b.below(e.rows.end - e.rows.begin - 1);
        let hl = e.len as usize;
        let f1 = run(c, &c.g, &e, rdesc.as_ref(), e.rows, hl);
        let f2 = run(c, &c.g, &e, rdesc.as_ref(), refl_row_range { begin: e.rows.begin, end: k }, hl);
        let f3 = run(c, &c.g, &e, rdesc.as_ref(), refl_row_range { begin: k, end: e.rows.end }, hl);
        assert!(f1.s == refl_status::Ok && f2.s == refl_status::Ok && f3.s == refl_status::Ok, "bands refused: {:?} {:?} {:?}: {}", f1.s, f2.s, f3.s, last_error());
        let split = (k * w) as usize;
        for i in 0..n {
            let part = if i < split { &f2 } else { &f3 };
            assert_eq!(f1.written[i], part.written[i], "texel {i} written by one call but not the bands (or back)");
            if f1.written[i] {
                assert!(same_texel(&f1.texels[i], &part.texels[i]), "texel {i} differs between one call and two bands");
            }
            assert!(!(f2.written[i] && f3.written[i]), "texel {i} written by both bands");
        }
        let sum = |a: &refl_cluster_stats, b: &refl_cluster_stats| refl_cluster_stats {
            pixels: a.pixels + b.pixels,
            hits: a.hits + b.hits,
            sky: a.sky + b.sky,
            host_rays: a.host_rays + b.host_rays,
            host_rays_written: a.host_rays_written + b.host_rays_written,
            rays: a.rays + b.rays,
            ray_hits: a.ray_hits + b.ray_hits,
            self_hits: a.self_hits + b.self_hits,
        };
        assert!(same_stats(&f1.st, &sum(&f2.st, &f3.st)), "stats of one call {:?} vs bands {:?} + {:?}", f1.st, f2.st, f3.st);
        let joined: Vec<_> = f2.host[..f2.st.host_rays_written as usize].iter().chain(&f3.host[..f3.st.host_rays_written as usize]).collect();
        assert_eq!(joined.len(), f1.st.host_rays_written as usize);
        for (a, j) in f1.host.iter().zip(joined) {
            assert!(same_host(a, j), "host list differs between one call and two bands");
        }
    }

    // Seed 003 Sec. 4.4's second way: the same call with
    // `second_intersection` and the reflector images.
    if let (true, Some(r)) = (is_cam && rare(b, 48), rdesc) {
        second_intersection(b, c, &e, r, rows, &out);
    }

    // A render of another camera (the same size): refused.
    if let (true, Some(mut r2)) = (is_cam && rare(b, 64), rdesc) {
        let c2 = &mut r2.depth.camera;
        c2.fov_y = if c2.fov_y > 1.0 { c2.fov_y * 0.9 } else { c2.fov_y * 1.1 };
        if camera_ok(c2) {
            let f = run(c, &c.g, &e, Some(&r2), rows, host_len);
            assert_eq!(f.s, refl_status::InvalidArgument, "a render of another camera was accepted");
            assert!(f.written.iter().all(|&x| !x), "refused but wrote");
        }
    }

    // A G-buffer without the entry's last row (the plan is of another
    // size): refused.
    if rare(b, 48) && e.rows.end >= 2 {
        let h2 = e.rows.end - 1;
        let mut g2 = c.g;
        g2.depth.camera.height = h2;
        g2.depth.depth.height = h2;
        g2.normals.height = h2;
        for img_h in [&mut g2.mask.height, &mut g2.roughness.height, &mut g2.color.height, &mut g2.back_depth.height] {
            *img_h = h2;
        }
        if camera_ok(&g2.depth.camera) {
            let f = run(c, &g2, &e, rdesc.as_ref(), refl_row_range { begin: 0, end: h2 }, host_len);
            assert!(f.s != refl_status::Ok, "an entry reaching row {} accepted for a G-buffer of {h2} rows", e.rows.end - 1);
            assert!(f.written.iter().all(|&x| !x), "refused but wrote");
        }
    }
}

/// `refl_cluster_finalize` over the band's pixels with the G-buffer's
/// surfaces as the pass reads them: bit for bit the pass's shades.
fn compare_kernel(c: &Ctx, e: &refl_cluster_plan_entry, r: &Render, band: &[u32], out: &Buf<refl_cluster_texel>, eye: refl_vec3) {
    if band.is_empty() {
        return;
    }
    let (w, h, n) = (c.w, c.h, c.n);
    let gcam = c.g.depth.camera;
    let mut pos = vec![v3(0.0, 0.0, 0.0); n];
    let mut nrm = vec![v3(0.0, 1.0, 0.0); n];
    for &p in band {
        let (x, y) = (p % w, p / w);
        let mut q = refl_vec3::default();
        // SAFETY: pointers valid.
        let us = unsafe { refl_camera_unproject(&mut q, &gcam, refl_vec2 { x: x as f32 + 0.5, y: y as f32 + 0.5 }, c.fg.img.texel(x, y), c.fg.img.conv) };
        if us != refl_status::Ok {
            return;
        }
        let Some(nn) = world_normal(c.fg.normal_at(x, y)) else { return };
        // Turned toward the eye; grazing views (the sign of n . v within
        // rounding) are left out.
        let v = [q.x - eye.x, q.y - eye.y, q.z - eye.z].map(f64::from);
        let vl = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let nd = d3(nn);
        let nv = (nd[0] * v[0] + nd[1] * v[1] + nd[2] * v[2]) / vl.max(1e-30);
        if !(nv.abs() > 1e-3) {
            return;
        }
        pos[p as usize] = q;
        nrm[p as usize] = if nv > 0.0 { v3(-nn.x, -nn.y, -nn.z) } else { nn };
    }
    let th = refl_trace_thickness {
        // A fraction of the pass's D (a glossy cluster's own far plane may be nearer).
        constant: c.o.thickness * c.o.camera.far_distance,
        back_faces: if r.back.is_null() { refl_image_f32 { data: core::ptr::null(), len: 0, width: 0, height: 0, stride: 0 } } else { r.desc.back_depth },
    };
    let input = refl_cluster_finalize_input { thickness: th, step: c.o.step, refine: c.o.refine, lobe: e.lobe, fade: c.o.fade && e.lobe.rays > 1, seed: c.o.seed, single_ray: c.o.glossy_single_ray };
    let mut shades = vec![refl_cluster_shade::default(); band.len()];
    let mut fb = 0u32;
    // SAFETY: every buffer valid for its length.
    let s = unsafe {
        refl_cluster_finalize(
            &mut fb,
            shades.as_mut_ptr(),
            shades.len(),
            refl_image_vec3 { data: pos.as_ptr(), len: n, width: w, height: h, stride: w },
            refl_image_vec3 { data: nrm.as_ptr(), len: n, width: w, height: h, stride: w },
            band.as_ptr(),
            band.len(),
            eye,
            &e.camera,
            &r.desc.depth,
            r.desc.color,
            &input,
        )
    };
    assert_eq!(s, refl_status::Ok, "refl_cluster_finalize refused what the pass finalized: {}", last_error());
    let mut fallbacks = 0;
    for (k, &p) in band.iter().enumerate() {
        let t = out.get(p as usize);
        assert!(same_shade(&t.shade, &shades[k]), "pixel {p}: pass shade {:?} vs refl_cluster_finalize {:?}", t.shade, shades[k]);
        fallbacks += u32::from(shades[k].env_weight > 0.0);
    }
    assert_eq!(fb, fallbacks, "refl_cluster_finalize fallbacks");
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);

    // Defaults: the documented values.
    let d = refl_cluster_pass_options_default();
    let cd = refl_cluster_camera_options_default();
    let sd = refl_step_options_default();
    assert!(options_in_range(&d), "defaults out of range: {d:?}");
    assert!(d.cluster.max_theta_bins == 13 && d.cluster.max_phi_bins == 8 && d.cluster.gain == 64.0, "cluster defaults {:?}", d.cluster);
    assert!(d.camera == cd, "camera defaults {:?} vs {cd:?}", d.camera);
    assert!(cd.far_distance == 100.0 && cd.cone_half_angle == 0.0 && cd.resolution_scale == 1.0 && cd.max_resolution == 2048 && cd.min_pixels == 4 && cd.max_f == 16.0, "{cd:?}");
    assert!(d.step.stride == sd.stride && d.step.max_steps == sd.max_steps && sd.stride == 1 && sd.max_steps == u32::MAX, "step defaults");
    assert!(d.thickness == 0.005 && d.refine && !d.fade && d.seed == 0 && d.t_min.to_bits() == 0 && d.t_max == f32::INFINITY && !d.second_intersection && !d.glossy_single_ray, "{d:?}");

    let fg = FuzzGBuffer::new(&mut b, [96; 4]);
    let img = &fg.img;
    let (w, h) = (img.width, img.height);
    let gcam = img.cam;
    let g = fg.desc();
    let o = options(&mut b);

    // Objects: an id per pixel, a lobe per object.
    let nobj = if rare(&mut b, 16) { 0 } else { 1 + b.below(4) };
    let small = u64::from(w) * u64::from(h) <= 400;
    let lobes: Vec<refl_cluster_lobe> = (0..nobj).map(|_| lobe(&mut b, small)).collect();
    let lkind = if nobj == 0 && b.chance(128) { PtrKind::Null } else { kind(&mut b, 24) };
    let lb = Buf::from_slice(&lobes, lkind);
    let (iw, ih) = if rare(&mut b, 8) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (w, h) };
    let istride = if rare(&mut b, 24) { b.stride(iw) } else { iw };
    let (imode, iseed) = (b.u8(), b.u8());
    let ineed = required_len(iw, ih, istride).unwrap_or(16).min(1 << 16);
    let ilen = len_ok(&mut b, ineed);
    let ikind = kind(&mut b, 16);
    let ist = istride.max(1) as usize;
    let mut ids = Buf::from_fn(ilen, ikind, |i| {
        let (x, y) = ((i % ist) as u32, (i / ist) as u32);
        if x < iw && y < ih {
            id_at(imode, iseed, x, y, iw, nobj)
        } else {
            1
        }
    });
    let objs = refl_cluster_objects {
        ids: refl_image_u32 { data: ids.cptr(), len: ids.len(), width: iw, height: ih, stride: istride },
        lobes: lb.cptr(),
        lobes_len: nobj as usize,
    };
    let ids_snap = ids.snapshot();
    let lobes_snap = lb.snapshot();
    let inputs_unchanged = |ids: &Buf<u32>, what: &str| {
        fg.assert_unchanged(what);
        ids.assert_unchanged(&ids_snap, what);
        lb.assert_unchanged(&lobes_snap, what);
    };
    let gb = Buf::from_slice(&[g], kind(&mut b, 24));
    let ob = Buf::from_slice(&[o], kind(&mut b, 24));
    let objb = Buf::from_slice(&[objs], kind(&mut b, 24));
    let args_mis = [gb.kind(), ob.kind(), objb.kind()].contains(&PtrKind::Misaligned);

    // 1. The size query.
    let mut lo = out1::<refl_cluster_plan_sizes>(kind(&mut b, 24));
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_cluster_plan_len(lo.ptr(), gb.cptr(), objb.cptr(), ob.cptr()) };
    let null = lo.is_null() || gb.is_null() || objb.is_null() || ob.is_null();
    null_rules_m(s, null, null, args_mis || lo.kind() == PtrKind::Misaligned, "refl_cluster_plan_len");
    on_error_untouched(s, &[("out", lo.is_sentinel(0))], "refl_cluster_plan_len");
    let mut sizes = refl_cluster_plan_sizes::default();
    // SAFETY: pointers valid.
    let qs = unsafe { refl_cluster_plan_len(&mut sizes, &g, &objs, &o) };
    null_rules(qs, false, false, "refl_cluster_plan_len");
    if s == refl_status::Ok {
        assert_eq!(lo.get(0), sizes, "plan_len differs between calls");
    }
    let mut bins_max = 0u32;
    // SAFETY: pointers valid.
    let bs = unsafe { refl_cluster_bins_max(&mut bins_max, nobj, &o.cluster) };
    let pixels = u64::from(gcam.width) * u64::from(gcam.height);
    let want = camera_ok(&gcam) && pixels > 0 && pixels <= u64::from(u32::MAX) && bs == refl_status::Ok;
    assert_eq!(qs == refl_status::Ok, want, "plan_len {qs:?} (camera {gcam:?}, bins_max {bs:?}): {}", last_error());
    if qs == refl_status::Ok {
        assert!(cluster_options_ok(&o.cluster), "plan_len accepted {:?}", o.cluster);
        let px = pixels as usize;
        // Header: 2 x width x height, then the offsets (one more than the
        // clusters, refl_cluster_bins_max) and four words per object
        // (finding F26a: the header said three).
        let doc = 2 * px + bins_max as usize + 1 + 4 * nobj as usize;
        assert_eq!(sizes.scratch_len, doc, "scratch_len but the header's formula ({gcam:?}, {nobj} objects, {:?})", o.cluster);
        assert!(sizes.clusters_len <= bins_max as usize && sizes.clusters_len <= px, "clusters_len {} > min(bins {bins_max}, pixels {px})", sizes.clusters_len);
    }

    // 2. The plan.
    let need_s = sizes.scratch_len;
    let need_c = sizes.clusters_len;
    let slen = if qs == refl_status::Ok && need_s <= 1 << 17 { len_ok(&mut b, need_s) } else { b.below(64) as usize };
    let clen = if qs == refl_status::Ok && need_c <= 1 << 13 { len_ok(&mut b, need_c) } else { b.below(8) as usize };
    let mut scratch = Buf::<u32>::sentinel(slen, kind(&mut b, 24));
    let mut clusters = Buf::<refl_cluster_plan_entry>::sentinel(clen, kind(&mut b, 24));
    let mut pst = out1::<refl_cluster_plan_stats>(kind(&mut b, 24));
    let alias = if rare(&mut b, 12) { 1 + b.below(4) } else { 0 };
    let (mut sp, mut sl, mut cp, mut cl, mut stp) = (scratch.ptr(), slen, clusters.ptr(), clen, pst.ptr());
    let mut alias_on = false;
    match alias {
        // The scratch over the id image (an input).
        1 if ids.usable() && !ids.is_empty() => {
            sp = ids.ptr();
            sl = ids.len();
            alias_on = true;
        }
        // The cluster list over the scratch.
        2 if scratch.usable() && slen * 4 >= size_of::<refl_cluster_plan_entry>() => {
            cp = sp.cast();
            cl = slen * 4 / size_of::<refl_cluster_plan_entry>();
            alias_on = true;
        }
        // The stats inside the scratch.
        3 if scratch.usable() && slen * 4 >= size_of::<refl_cluster_plan_stats>() => {
            stp = sp.cast();
            alias_on = true;
        }
        // The scratch over the lobes (an input).
        4 if lb.usable() && nobj > 0 => {
            sp = lb.cptr().cast_mut().cast();
            sl = nobj as usize * 3;
            alias_on = true;
        }
        _ => {}
    }
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_cluster_plan(stp, cp, cl, sp, sl, gb.cptr(), objb.cptr(), ob.cptr()) };
    let what = "refl_cluster_plan";
    let req_null = stp.is_null() || cp.is_null() || sp.is_null() || gb.is_null() || ob.is_null();
    let late_null = objb.is_null() || (lb.is_null() && nobj > 0);
    let any_null = req_null || late_null || ids.is_null() || img.buf.is_null() || fg.normals.0.is_null();
    let mis = misal(sp) || misal(cp) || misal(stp) || args_mis;
    null_rules_m(s, req_null, any_null, mis, what);
    on_error_untouched(
        s,
        &[
            ("out_stats", pst.is_sentinel(0)),
            ("clusters", all_sentinel(&clusters, 0)),
            ("scratch", all_sentinel(&scratch, 0)),
        ],
        what,
    );
    inputs_unchanged(&ids, what);
    if alias_on {
        assert!(s != refl_status::Ok, "{what} accepted aliased outputs ({alias})");
    }
    // A NULL `objects` or `lobes` read after the G-buffer: another bad
    // argument may be reported, but then the call fails with it valid too.
    if !req_null && late_null && s != refl_status::NullPointer && s != refl_status::Ok && !alias_on {
        let lobes2 = Buf::from_slice(&lobes, PtrKind::Valid);
        let objs2 = refl_cluster_objects { lobes: lobes2.cptr(), ..objs };
        let mut s2b = Buf::<u32>::sentinel(slen, scratch.kind());
        let mut c2b = Buf::<refl_cluster_plan_entry>::sentinel(clen, clusters.kind());
        let mut st2 = out1::<refl_cluster_plan_stats>(pst.kind());
        // SAFETY: as above, with valid objects.
        let s2 = unsafe { refl_cluster_plan(st2.ptr(), c2b.ptr(), clen, s2b.ptr(), slen, gb.cptr(), &objs2, ob.cptr()) };
        assert!(s2 != refl_status::Ok, "{what}: a NULL objects/lobes reported as {s:?} though it was the only bad argument");
    }
    let all_valid = qs == refl_status::Ok
        && gbuffer_valid(&fg)
        && options_in_range(&o)
        && img_ok(&ids, iw, ih, istride, w, h)
        && lobes.iter().all(lobe_valid)
        && (nobj == 0 || lb.usable())
        && [gb.kind(), ob.kind(), objb.kind(), scratch.kind(), clusters.kind(), pst.kind()].iter().all(|&k| k == PtrKind::Valid)
        && !alias_on
        && slen >= need_s
        && clen >= need_c;
    if all_valid {
        assert_eq!(s, refl_status::Ok, "{what} refused valid input: {}", last_error());
    }
    if s != refl_status::Ok {
        return;
    }
    assert_eq!(qs, refl_status::Ok, "plan accepted what plan_len refused");
    assert!(options_in_range(&o), "plan accepted options {o:?}");
    fg.assert_accepted("plan");
    assert!(img_ok(&ids, iw, ih, istride, w, h), "plan accepted an id image of {iw}x{ih} (stride {istride}, len {}) for {w}x{h}", ids.len());
    assert!(lobes.iter().all(lobe_valid), "plan accepted lobes {lobes:?}");
    assert!(slen >= need_s && clen >= need_c, "plan accepted scratch {slen} / clusters {clen} of {need_s} / {need_c}");

    // The plan's outputs.
    let n = w as usize * h as usize;
    let st = pst.get(0);
    let nc = st.clusters as usize;
    assert!(nc <= need_c, "{nc} clusters > clusters_len {need_c}");
    assert!(st.bins <= bins_max, "bins {} > {bins_max}", st.bins);
    assert!(all_sentinel(&clusters, nc), "plan wrote an entry past its {nc} clusters");
    assert!(all_sentinel(&scratch, need_s), "plan wrote scratch past scratch_len {need_s}");
    let entries: Vec<refl_cluster_plan_entry> = (0..nc).map(|i| clusters.get(i)).collect();
    let eye = eye_of(&gcam);
    let cmo = &o.camera;
    let (mut cams, mut planar, mut total) = (0u32, 0u32, 0usize);
    let mut prev_id: Option<u32> = None;
    for (k, e) in entries.iter().enumerate() {
        assert!(prev_id.is_none_or(|p| e.id > p), "entry {k}: ids not increasing");
        prev_id = Some(e.id);
        assert!(e.id < st.bins, "entry {k}: id {} of {} bins", e.id, st.bins);
        assert!(e.object < nobj, "entry {k}: object {} of {nobj}", e.object);
        assert!(same_lobe(&e.lobe, &lobes[e.object as usize]), "entry {k}: lobe {:?} vs the object's {:?}", e.lobe, lobes[e.object as usize]);
        assert!(e.len >= 1 && e.first as usize + e.len as usize <= n, "entry {k}: pixels {}..+{} of {n}", e.first, e.len);
        total += e.len as usize;
        let mut last: Option<u32> = None;
        for j in 0..e.len as usize {
            let p = scratch.get(n + e.first as usize + j);
            assert!((p as usize) < n, "entry {k}: pixel {p} outside the image");
            assert!(last.is_none_or(|q| p > q), "entry {k}: pixels not in raster order");
            last = Some(p);
            let (x, y) = (p % w, p / w);
            assert_eq!(scratch.get(p as usize), e.id, "entry {k}: pixel {p}'s cluster id");
            assert_eq!(ids.get((y * istride + x) as usize), e.object, "entry {k}: pixel ({x}, {y}) of another object");
            assert!(!fg.masked(x, y), "masked pixel ({x}, {y}) in a cluster");
            assert!(!fg.roughness_at(x, y).is_some_and(f32::is_nan), "pixel ({x}, {y}) with a NaN roughness in a cluster");
        }
        let (p0, p1) = (scratch.get(n + e.first as usize), scratch.get(n + e.first as usize + e.len as usize - 1));
        assert!(e.rows.begin == p0 / w && e.rows.end == p1 / w + 1, "entry {k}: rows {:?} for pixels {p0}..{p1} ({w} wide)", e.rows);
        let cc = &e.camera;
        assert!(cc.fallback <= FB_LAST, "entry {k}: fallback {}", cc.fallback);
        assert_eq!(cc.fallback == FB_TOO_FEW, e.len < cmo.min_pixels, "entry {k}: {} pixels, min {}, fallback {}", e.len, cmo.min_pixels, cc.fallback);
        if cc.fallback != 0 {
            assert!(fallback_fields_zero(cc), "entry {k}: fallback record with fields {cc:?}");
            assert!(e.frustum.iter().all(|p| [p.x, p.y, p.z, p.w].iter().all(|v| v.to_bits() == 0)), "entry {k}: frustum of a fallback");
            continue;
        }
        cams += 1;
        planar += u32::from(cc.planar);
        let c = &cc.camera;
        assert!(camera_ok(c), "entry {k}: camera {c:?} does not validate");
        assert!(c.width >= 1 && c.height >= 1 && c.width <= cmo.max_resolution && c.height <= cmo.max_resolution, "entry {k}: {}x{} (max {})", c.width, c.height, cmo.max_resolution);
        assert!(cc.f > 0.0 && cc.f <= cmo.max_f, "entry {k}: f {} (max_f {})", cc.f, cmo.max_f);
        if cc.planar {
            assert_eq!(cc.f, 1.0, "entry {k}: planar f");
            if let Some(ce) = eye_of(c) {
                let tol = 1e-4 * (1.0 + len3(cc.eye0));
                let dd = [ce.x - cc.eye0.x, ce.y - cc.eye0.y, ce.z - cc.eye0.z];
                assert!(len3(v3(dd[0], dd[1], dd[2])) <= tol, "entry {k}: planar camera eye {ce:?} vs e_0 {:?}", cc.eye0);
            }
        }
        assert!((len3(cc.normal) - 1.0).abs() < 1e-4 && (len3(cc.clip.normal) - 1.0).abs() < 1e-4, "entry {k}: normals {cc:?}");
        assert!(finite3(cc.centroid) && finite3(cc.eye0) && cc.clip.d.is_finite(), "entry {k}: {cc:?}");
        // D, or for a glossy lobe min(D, r / tan(max_angle)) (seed 003 Sec. 3.5 item 2).
        let near = f64::from(cmo.glossy_blur_radius) / f64::from(e.lobe.max_angle).tan();
        if e.lobe.rays > 1 && near < f64::from(cmo.far_distance) * (1.0 - 1e-5) {
            // Relative in f32's normal range; a subnormal D (a subnormal r) keeps fewer bits.
            let diff = (f64::from(cc.far_distance) - near).abs();
            assert!(diff <= 1e-5 * near || diff <= 2.0 * f64::from(f32::MIN_POSITIVE), "entry {k}: glossy D {} vs min(D, r / tan) {near} (D {})", cc.far_distance, cmo.far_distance);
        } else if e.lobe.rays > 1 {
            assert!(cc.far_distance <= cmo.far_distance && f64::from(cc.far_distance) >= near.min(f64::from(cmo.far_distance)) * (1.0 - 1e-5), "entry {k}: glossy D {} (D {}, r / tan {near})", cc.far_distance, cmo.far_distance);
        } else {
            assert!(cc.far_distance.to_bits() == cmo.far_distance.to_bits(), "entry {k}: D {} vs {}", cc.far_distance, cmo.far_distance);
        }
        assert!(cc.pixels_used >= 1 && cc.pixels_used <= e.len, "entry {k}: pixels_used {} of {}", cc.pixels_used, e.len);
        if let Some(ey) = eye {
            let v = [ey.x - cc.centroid.x, ey.y - cc.centroid.y, ey.z - cc.centroid.z].map(f64::from);
            let nn = d3(cc.normal);
            let vl = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            assert!(v[0] * nn[0] + v[1] * nn[1] + v[2] * nn[2] >= -1e-4 * vl, "entry {k}: mean normal {:?} faces away from the eye", cc.normal);
        }
        // The frustum: unit inward normals, holding the view's center ray
        // between the near and far planes. With an infinite far plane the
        // last plane is (0, 0, 0, 1), no bound (`refl_camera_frustum_planes`,
        // `Camera::frustum_planes`; F35: the target expected a unit normal).
        for (pi, p) in e.frustum.iter().enumerate() {
            if pi == 5 && c.z_far.is_infinite() {
                assert!([p.x, p.y, p.z, p.w].map(f32::to_bits) == [0.0f32, 0.0, 0.0, 1.0].map(f32::to_bits), "entry {k}: far plane {p:?} of an infinite far plane");
                continue;
            }
            let l = len3(v3(p.x, p.y, p.z));
            assert!((l - 1.0).abs() < 1e-3 && p.w.is_finite(), "entry {k}: frustum plane {p:?}");
        }
        let mut ray = refl_ray::default();
        // SAFETY: pointers valid.
        if unsafe { refl_camera_primary_ray(&mut ray, c, refl_vec2 { x: c.width as f32 * 0.5, y: c.height as f32 * 0.5 }) } == refl_status::Ok && c.z_far.is_finite() {
            let z = 0.5 * (f64::from(c.z_near) + f64::from(c.z_far));
            let q = [0, 1, 2].map(|a| d3(ray.origin)[a] + z * d3(ray.dir)[a]);
            let ql = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
            for (pi, p) in e.frustum.iter().enumerate() {
                let dist = f64::from(p.x) * q[0] + f64::from(p.y) * q[1] + f64::from(p.z) * q[2] + f64::from(p.w);
                let tol = 1e-3 * (1.0 + ql + f64::from(p.w.abs()) + z);
                assert!(dist >= -tol, "entry {k}: the view's center at depth {z} is outside frustum plane {pi} ({p:?}): {dist}");
            }
        }
    }
    assert_eq!((st.cameras, st.planar_cameras, st.pixels as usize), (cams, planar, total), "plan stats {st:?}");
    // Every reflective pixel (an id below lobes_len, mask not 0, roughness
    // not NaN, a usable surface) is in a cluster. Checked where the target
    // can tell the surface usable: world-space normals, a depth well
    // inside [near, far), a view that is not grazing.
    if let (0, Some(ey)) = (fg.normal_space, eye) {
        let mut clustered = vec![false; n];
        for e in &entries {
            for j in 0..e.len as usize {
                clustered[scratch.get(n + e.first as usize + j) as usize] = true;
            }
        }
        // A sample of at most 48 pixels (each costs two camera calls).
        let step = n.div_ceil(48).max(1);
        for p in (0..n).step_by(step) {
            let (x, y) = ((p % w as usize) as u32, (p / w as usize) as u32);
            let id = ids.get((y * istride + x) as usize);
            if id >= nobj || fg.masked(x, y) || fg.roughness_at(x, y).is_some_and(f32::is_nan) {
                continue;
            }
            let Some(nn) = world_normal(fg.normal_at(x, y)) else { continue };
            let d = img.texel(x, y);
            let Some(z) = decode(&gcam, d, img.conv) else { continue };
            if !(z.is_finite() && z > gcam.z_near * 1.001 && z < gcam.z_far * 0.999) {
                continue;
            }
            let mut q = refl_vec3::default();
            // SAFETY: pointers valid.
            if unsafe { refl_camera_unproject(&mut q, &gcam, refl_vec2 { x: x as f32 + 0.5, y: y as f32 + 0.5 }, d, img.conv) } != refl_status::Ok {
                continue;
            }
            let v = [q.x - ey.x, q.y - ey.y, q.z - ey.z].map(f64::from);
            let vl = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            let nd = d3(nn);
            if !(vl > 1e-6 * (1.0 + len3(q))) || !(((nd[0] * v[0] + nd[1] * v[1] + nd[2] * v[2]) / vl).abs() > 1e-3) {
                continue;
            }
            // (Finding F26b, fixed: a surface farther from the eye than
            // f32's |v|^2 holds, ~1.8e19, got no mirror ray.)
            assert!(clustered[(y * w + x) as usize], "reflective pixel ({x}, {y}) (object {id}, depth {z}, distance {vl}) in no cluster");
        }
    }

    // 3. Finalize a few entries.
    if nc == 0 {
        return;
    }
    let ctx = Ctx { fg: &fg, g, o, scratch: &scratch, slen, w, h, n, eye };
    for _ in 0..1 + b.below(3) {
        let k = b.below(nc as u32) as usize;
        finalize(&mut b, &ctx, &entries[k], &gb, &ob);
    }
});
