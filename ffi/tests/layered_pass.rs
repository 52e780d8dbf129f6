//! refl_layered_pass_* / refl_layered_trace_rows / refl_layered_trace_host_rays:
//! the C pass equals refl-core's `LayeredPass` bit for bit (every
//! convention, with and without ids, whole image, row bands from threads,
//! ray lists), the prepared scratch equals refl-core's, error paths return
//! their documented status and leave every output untouched, and no export
//! allocates (the counting global allocator of `common/gbuffer.rs`).

#[path = "common/gbuffer.rs"]
mod common;

use common::{
    bands_from_threads, color_mut, counted, no_color, refused_outputs, render, Frame,
    HostRaysWritten, Shared, H, W,
};
use refl::*;
use refl_core::glam::{Affine3A, Quat, Vec3};
use refl_core::layered::{Face, LayerHit, LayeredGrid, LayeredMap, LayeredMapMut};
use refl_core::{
    layered_pass_scratch_len, try_prepare_layered_pass, try_prr_masks, DepthConvention, HostRay,
    ImageView, ImageViewMut, LayeredBound, LayeredHostRay, LayeredPass, LayeredPassOptions,
    LayeredPassTexel, MirrorOptions, MirrorPass, MirrorTexel, PrrTriangle,
};

impl HostRaysWritten for refl_layered_pass_stats {
    fn host_rays_written(&self) -> u32 {
        self.host_rays_written
    }
}

/// Owned buffers of one map.
struct Owned {
    grid: LayeredGrid,
    depth: Vec<f32>,
    payload: Vec<u32>,
    counts: Vec<u32>,
    bounds: Vec<f32>,
}

impl Owned {
    fn map(&self) -> LayeredMap<'_> {
        LayeredMap::try_new(
            self.grid,
            &self.depth,
            &self.payload,
            &self.counts,
            &self.bounds,
        )
        .unwrap()
    }

    fn c(&self) -> refl_layered_map {
        refl_layered_map {
            grid: (&self.grid).into(),
            depth: self.depth.as_ptr(),
            depth_len: self.depth.len(),
            payload: self.payload.as_ptr(),
            payload_len: self.payload.len(),
            counts: self.counts.as_ptr(),
            counts_len: self.counts.len(),
            bounds: self.bounds.as_ptr(),
            bounds_len: self.bounds.len(),
        }
    }
}

/// The map of a sphere (`center`, `radius`) from its exact column
/// crossings, its grid placed by `placement` (the local box is the sphere's
/// around the origin, padded 2%); payload a packed color.
fn sphere_map(center: Vec3, radius: f32, rot: Quat, res: u32, payload: u32) -> Owned {
    let e = Vec3::splat(radius * 1.02);
    let grid = LayeredGrid::try_new(-e, e, res, 1)
        .unwrap()
        .try_with_transform(Affine3A::from_rotation_translation(rot, center))
        .unwrap();
    let len = grid.len();
    let mut o = Owned {
        grid,
        depth: vec![0.0; len.depth],
        payload: vec![0; len.payload],
        counts: vec![0; len.counts],
        bounds: vec![0.0; len.bounds],
    };
    {
        let mut m = LayeredMapMut::try_new(
            grid,
            &mut o.depth,
            &mut o.payload,
            &mut o.counts,
            &mut o.bounds,
        )
        .unwrap();
        m.clear();
        for face in [Face::NegX, Face::NegY, Face::NegZ] {
            for j in 0..res {
                for i in 0..res {
                    let r = grid.try_face_ray(face, i, j).unwrap();
                    let (oo, d) = (r.origin.as_dvec3() - center.as_dvec3(), r.dir.as_dvec3());
                    let b = oo.dot(d);
                    let disc = b * b - (oo.dot(oo) - f64::from(radius).powi(2));
                    let mut hits = Vec::new();
                    if disc > 0.0 {
                        let q = disc.sqrt();
                        hits.push(LayerHit {
                            t: (-b - q) as f32,
                            id: payload,
                            front: true,
                        });
                        hits.push(LayerHit {
                            t: (-b + q) as f32,
                            id: payload,
                            front: false,
                        });
                    }
                    m.try_fill_column(face, i, j, &mut hits).unwrap();
                }
            }
        }
        m.build_bounds();
    }
    o
}

/// The frame's sphere (object 1) and a smaller rotated sphere off the
/// frame's objects (object 5: seen only in reflections).
fn maps() -> [Owned; 2] {
    [
        sphere_map(
            Vec3::new(0.0, 1.0, 0.0),
            1.0,
            Quat::IDENTITY,
            40,
            0x00ff_8040,
        ),
        sphere_map(
            Vec3::new(1.9, 0.6, 1.2),
            0.6,
            Quat::from_rotation_y(0.7) * Quat::from_rotation_x(0.3),
            24,
            0x0030_2010,
        ),
    ]
}

const MAP_IDS: [u32; 2] = [1, 5];

fn option_sets() -> Vec<LayeredPassOptions> {
    let d = LayeredPassOptions::default();
    vec![
        d,
        LayeredPassOptions {
            payload_color: true,
            start_pixels: 2.0,
            t_max: 5.0,
            ..d
        },
    ]
}

/// The C input over the frame and the maps' descriptors.
fn input(f: &Frame, descs: &[refl_layered_map], ids: bool) -> refl_layered_pass_input {
    refl_layered_pass_input {
        gbuffer: f.gbuffer_c(false),
        maps: descs.as_ptr(),
        maps_len: descs.len(),
        ids: if ids {
            refl_image_u32 {
                data: f.ids.as_ptr(),
                len: f.ids.len(),
                width: W,
                height: H,
                stride: W,
            }
        } else {
            refl_image_u32 {
                data: core::ptr::null(),
                len: 0,
                width: 0,
                height: 0,
                stride: 0,
            }
        },
        map_ids: if ids {
            MAP_IDS.as_ptr()
        } else {
            core::ptr::null()
        },
        map_ids_len: if ids { MAP_IDS.len() } else { 0 },
        regions: refl_image_u32 {
            data: core::ptr::null(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        },
        region_masks: core::ptr::null(),
        region_masks_len: 0,
    }
}

/// `inp` with per-pixel `regions` (W x H) and their `masks`.
fn with_regions(
    inp: &refl_layered_pass_input,
    regions: &[u32],
    masks: &[u64],
) -> refl_layered_pass_input {
    refl_layered_pass_input {
        regions: refl_image_u32 {
            data: regions.as_ptr(),
            len: regions.len(),
            width: W,
            height: H,
            stride: W,
        },
        region_masks: masks.as_ptr(),
        region_masks_len: masks.len(),
        ..*inp
    }
}

fn prepare(
    inp: &refl_layered_pass_input,
    o: &refl_layered_pass_options,
) -> (Vec<refl_layered_bound>, u64) {
    let mut len = usize::MAX;
    // SAFETY: valid pointers.
    let (s, a0) = counted(|| unsafe { refl_layered_pass_scratch_len(&mut len, inp, o) });
    assert_eq!(s, refl_status::Ok);
    let mut scratch = vec![refl_layered_bound::default(); len];
    // SAFETY: valid pointers.
    let (s, a1) =
        counted(|| unsafe { refl_layered_pass_prepare(scratch.as_mut_ptr(), len, inp, o) });
    assert_eq!(s, refl_status::Ok, "{}", last_error());
    (scratch, a0 + a1)
}

struct CRun {
    texels: Vec<refl_layered_pass_texel>,
    color: Vec<[f32; 3]>,
    host: Vec<refl_host_ray>,
    stats: refl_layered_pass_stats,
}

fn c_run(
    inp: &refl_layered_pass_input,
    o: &refl_layered_pass_options,
    scratch: &[refl_layered_bound],
    with_color: bool,
) -> (refl_status, CRun, u64) {
    let n = (W * H) as usize;
    let mut r = CRun {
        texels: vec![refl_layered_pass_texel::default(); n],
        color: vec![[7.0; 3]; n],
        host: vec![refl_host_ray::default(); n],
        stats: refl_layered_pass_stats::default(),
    };
    let cm = if with_color {
        color_mut(&mut r.color)
    } else {
        no_color()
    };
    let (s, allocs) = counted(|| {
        // SAFETY: valid buffers of the stated lengths.
        unsafe {
            refl_layered_trace_rows(
                &mut r.stats,
                r.texels.as_mut_ptr(),
                n,
                cm,
                r.host.as_mut_ptr(),
                n,
                inp,
                o,
                scratch.as_ptr(),
                scratch.len(),
                refl_row_range { begin: 0, end: H },
            )
        }
    });
    r.host.truncate(r.stats.host_rays_written as usize);
    (s, r, allocs)
}

fn texel_bits(t: &refl_layered_pass_texel) -> [u32; 18] {
    [
        t.status,
        t.map,
        t.face,
        t.texel_x,
        t.texel_y,
        t.uv.x.to_bits(),
        t.uv.y.to_bits(),
        t.layer,
        t.payload,
        t.t.to_bits(),
        t.position.x.to_bits(),
        t.position.y.to_bits(),
        t.position.z.to_bits(),
        t.confidence.to_bits(),
        t.dir.x.to_bits(),
        t.dir.y.to_bits(),
        t.dir.z.to_bits(),
        t.fetches,
    ]
}

fn host_bits(a: &refl_host_ray) -> (u32, u32, u32, [u32; 8]) {
    (
        a.x,
        a.y,
        a.status,
        [
            a.origin.x, a.origin.y, a.origin.z, a.dir.x, a.dir.y, a.dir.z, a.t_min, a.t_max,
        ]
        .map(f32::to_bits),
    )
}

fn ids_view(f: &Frame) -> ImageView<'_, u32> {
    ImageView::try_new(&f.ids, W, H, W).unwrap()
}

/// The Rust pass over the same frame and maps.
fn rust_pass<'a>(
    f: &'a Frame,
    views: &'a [LayeredMap<'a>],
    bounds: &'a [LayeredBound],
    o: LayeredPassOptions,
    ids: bool,
) -> LayeredPass<'a> {
    let p = LayeredPass::try_new(f.gbuffer(false), views, o, bounds).unwrap();
    if ids {
        p.try_with_ids(ids_view(f), &MAP_IDS).unwrap()
    } else {
        p
    }
}

#[test]
fn options_default_is_the_rust_default() {
    let c = refl_layered_pass_options_default();
    assert_eq!(c, LayeredPassOptions::default().into());
    assert_eq!(LayeredPassOptions::from(c), LayeredPassOptions::default());
    assert_eq!(c.trace, refl_layered_options_default());
    assert!(!c.payload_color && c.t_max == f32::INFINITY && c.start_pixels == 0.0);
}

#[test]
fn c_pass_equals_the_rust_pass_bit_for_bit_without_allocating() {
    let owned = maps();
    let views = [owned[0].map(), owned[1].map()];
    let descs = [owned[0].c(), owned[1].c()];
    let mut hits = [0u32; 2];
    for conv in [
        DepthConvention::Linear,
        DepthConvention::ZeroToOne,
        DepthConvention::ReversedZ,
    ] {
        let f = render(conv);
        for o in option_sets() {
            let oc: refl_layered_pass_options = o.into();
            for ids in [false, true] {
                let inp = input(&f, &descs, ids);
                let (scratch, a_prep) = prepare(&inp, &oc);
                // The scratch is refl-core's.
                let mut rb = vec![LayeredBound::default(); layered_pass_scratch_len(&views[..])];
                try_prepare_layered_pass(&mut rb, &f.gbuffer(false), &views[..], &o).unwrap();
                assert_eq!(scratch.len(), rb.len());
                for (a, b) in scratch.iter().zip(&rb) {
                    assert_eq!(
                        (
                            a.center.x.to_bits(),
                            a.center.y.to_bits(),
                            a.center.z.to_bits(),
                            a.radius.to_bits(),
                            a.key
                        ),
                        (
                            b.center[0].to_bits(),
                            b.center[1].to_bits(),
                            b.center[2].to_bits(),
                            b.radius.to_bits(),
                            b.key
                        )
                    );
                }
                let (s, c, a_run) = c_run(&inp, &oc, &scratch, o.payload_color);
                assert_eq!(s, refl_status::Ok, "{}", last_error());
                assert_eq!((a_prep, a_run), (0, 0), "allocations in refl_layered_*");
                let pass = rust_pass(&f, &views, &rb, o, ids);
                let np = (W * H) as usize;
                let mut out = vec![LayeredPassTexel::default(); np];
                let mut color = vec![[0.0f32; 3]; np];
                let mut host = vec![LayeredHostRay::default(); np];
                let st = pass
                    .try_run(
                        &mut ImageViewMut::try_new(&mut out, W, H, W).unwrap(),
                        o.payload_color
                            .then_some(&mut ImageViewMut::try_new(&mut color, W, H, W).unwrap()),
                        &mut host,
                    )
                    .unwrap();
                assert_eq!(c.stats, st.into());
                for i in 0..np {
                    assert_eq!(
                        texel_bits(&c.texels[i]),
                        texel_bits(&out[i].into()),
                        "{conv:?} {i}"
                    );
                    if out[i].status == refl_core::LayeredPassStatus::Hit {
                        hits[out[i].map as usize] += 1;
                    }
                    if o.payload_color {
                        assert_eq!(c.color[i].map(f32::to_bits), color[i].map(f32::to_bits));
                    }
                }
                assert_eq!(c.host.len(), st.host_rays_written as usize);
                for (a, b) in c.host.iter().zip(&host) {
                    assert_eq!(host_bits(a), host_bits(&(*b).into()));
                }
            }
        }
    }
    assert!(hits[0] > 100 && hits[1] > 20, "{hits:?}");
}

#[test]
fn row_bands_from_threads_equal_the_whole_image() {
    let owned = maps();
    let descs = [owned[0].c(), owned[1].c()];
    let f = render(DepthConvention::ReversedZ);
    for o in option_sets() {
        let oc: refl_layered_pass_options = o.into();
        let inp = input(&f, &descs, true);
        let (scratch, _) = prepare(&inp, &oc);
        let (_, whole, _) = c_run(&inp, &oc, &scratch, o.payload_color);
        let n = (W * H) as usize;
        let mut texels = vec![refl_layered_pass_texel::default(); n];
        let mut color = vec![[7.0f32; 3]; n];
        let shared = Shared(inp);
        let with_color = o.payload_color;
        let runs = bands_from_threads(
            &mut texels,
            &mut color,
            5,
            &|st, out, out_len, c, host, host_len, rows| {
                let c = if with_color { c } else { no_color() };
                // SAFETY: valid buffers; each band writes only its own rows.
                unsafe {
                    refl_layered_trace_rows(
                        st,
                        out,
                        out_len,
                        c,
                        host,
                        host_len,
                        shared.get(),
                        &oc,
                        scratch.as_ptr(),
                        scratch.len(),
                        rows,
                    )
                }
            },
        );
        assert_eq!(texels, whole.texels);
        assert_eq!(color, whole.color);
        let hosts: Vec<refl_host_ray> = runs.iter().flat_map(|r| r.0.clone()).collect();
        assert_eq!(hosts, whole.host);
        let sum = runs
            .iter()
            .fold(refl_layered_pass_stats::default(), |a, (_, s)| {
                refl_layered_pass_stats {
                    traced: a.traced + s.traced,
                    hits: a.hits + s.hits,
                    sky: a.sky + s.sky,
                    host_rays: a.host_rays + s.host_rays,
                    host_rays_written: a.host_rays_written + s.host_rays_written,
                    kernel_traces: a.kernel_traces + s.kernel_traces,
                    fetches: a.fetches + s.fetches,
                    sphere_culled: a.sphere_culled + s.sphere_culled,
                    prr_skipped: a.prr_skipped + s.prr_skipped,
                }
            });
        assert_eq!(sum, whole.stats);
    }
}

/// The mirror pass's host rays, as `refl_ssr_trace_rows` writes them,
/// traced by `refl_layered_trace_host_rays`, equal refl-core's
/// `try_trace_rays` on the same rays.
#[test]
fn host_ray_lists_equal_the_rust_pass() {
    let owned = maps();
    let views = [owned[0].map(), owned[1].map()];
    let descs = [owned[0].c(), owned[1].c()];
    let f = render(DepthConvention::Linear);
    let mp = MirrorPass::try_new(f.gbuffer(false), MirrorOptions::default(), None).unwrap();
    let np = (W * H) as usize;
    let mut mt = vec![MirrorTexel::default(); np];
    let mut screen = vec![HostRay::default(); np];
    let st = mp
        .try_run(
            &mut ImageViewMut::try_new(&mut mt, W, H, W).unwrap(),
            None,
            &mut screen,
        )
        .unwrap();
    screen.truncate(st.host_rays_written as usize);
    assert!(screen.len() > 100);
    let rays: Vec<refl_host_ray> = screen.iter().map(|r| refl_host_ray::from(*r)).collect();
    for o in option_sets() {
        let oc: refl_layered_pass_options = o.into();
        for ids in [false, true] {
            let inp = input(&f, &descs, ids);
            let (scratch, _) = prepare(&inp, &oc);
            let k = rays.len();
            let mut out = vec![refl_layered_pass_texel::default(); k];
            let mut color = vec![refl_vec3::default(); k];
            let mut host = vec![refl_host_ray::default(); k];
            let mut stats = refl_layered_pass_stats::default();
            let cp = if o.payload_color {
                color.as_mut_ptr()
            } else {
                core::ptr::null_mut()
            };
            let cl = if o.payload_color { k } else { 0 };
            let (s, allocs) = counted(|| {
                // SAFETY: valid buffers of the stated lengths.
                unsafe {
                    refl_layered_trace_host_rays(
                        &mut stats,
                        out.as_mut_ptr(),
                        k,
                        cp,
                        cl,
                        host.as_mut_ptr(),
                        k,
                        &inp,
                        &oc,
                        scratch.as_ptr(),
                        scratch.len(),
                        rays.as_ptr(),
                        k,
                    )
                }
            });
            assert_eq!((s, allocs), (refl_status::Ok, 0), "{}", last_error());
            let mut rb = vec![LayeredBound::default(); 2];
            try_prepare_layered_pass(&mut rb, &f.gbuffer(false), &views[..], &o).unwrap();
            let pass = rust_pass(&f, &views, &rb, o, ids);
            let mut rout = vec![LayeredPassTexel::default(); k];
            let mut rcolor = vec![[0.0f32; 3]; k];
            let mut rhost = vec![LayeredHostRay::default(); k];
            let rst = pass
                .try_trace_rays(
                    &mut rout,
                    o.payload_color.then_some(&mut rcolor[..]),
                    &mut rhost,
                    &screen,
                )
                .unwrap();
            assert_eq!(stats, rst.into());
            assert!(rst.hits > 0);
            for i in 0..k {
                assert_eq!(texel_bits(&out[i]), texel_bits(&rout[i].into()));
                if o.payload_color {
                    assert_eq!([color[i].x, color[i].y, color[i].z], rcolor[i]);
                }
            }
            for i in 0..rst.host_rays_written as usize {
                assert_eq!(host_bits(&host[i]), host_bits(&rhost[i].into()));
            }
        }
    }
}

fn last_error() -> String {
    let mut buf = [0u8; 256];
    // SAFETY: valid buffer.
    let k = unsafe { refl_last_error_message(buf.as_mut_ptr().cast(), buf.len()) };
    String::from_utf8_lossy(&buf[..k.min(255)]).to_string()
}

/// `refl_layered_trace_rows` with sentinel outputs: the status, nothing
/// written, nothing allocated.
fn refused(
    want: refl_status,
    inp: *const refl_layered_pass_input,
    o: *const refl_layered_pass_options,
    scratch: &[refl_layered_bound],
    rows: refl_row_range,
    out_len: usize,
    with_color: bool,
) {
    let texel = refl_layered_pass_texel {
        status: 99,
        t: -3.0,
        ..Default::default()
    };
    let stats = refl_layered_pass_stats {
        traced: 55,
        ..Default::default()
    };
    refused_outputs(
        want,
        texel,
        stats,
        with_color,
        |st, out, cm, host, host_len| {
            // SAFETY: valid buffers (out_len <= n) or NULL descriptors.
            unsafe {
                refl_layered_trace_rows(
                    st,
                    out,
                    out_len,
                    cm,
                    host,
                    host_len,
                    inp,
                    o,
                    scratch.as_ptr(),
                    scratch.len(),
                    rows,
                )
            }
        },
    );
}

/// `refl_layered_pass_prepare` into a sentinel scratch of `len` records.
fn prepare_refused(
    want: refl_status,
    inp: &refl_layered_pass_input,
    o: &refl_layered_pass_options,
    len: usize,
) {
    let sentinel = refl_layered_bound {
        key: 99,
        ..Default::default()
    };
    let mut scratch = vec![sentinel; len.max(1)];
    // SAFETY: valid pointers.
    let (s, allocs) =
        counted(|| unsafe { refl_layered_pass_prepare(scratch.as_mut_ptr(), len, inp, o) });
    assert_eq!(s, want, "{}", last_error());
    assert_eq!(allocs, 0);
    assert!(scratch.iter().all(|b| *b == sentinel));
}

/// The inputs of the error tests: the two maps, their C descriptors and
/// the ZeroToOne scene.
struct ErrorSetup {
    owned: [Owned; 2],
    descs: [refl_layered_map; 2],
    f: Frame,
}

impl ErrorSetup {
    fn new() -> ErrorSetup {
        let owned = maps();
        let descs = [owned[0].c(), owned[1].c()];
        ErrorSetup {
            owned,
            descs,
            f: render(DepthConvention::ZeroToOne),
        }
    }

    /// The pass input with ids, the default options and a scratch
    /// prepared for them.
    fn c(
        &self,
    ) -> (
        refl_layered_pass_input,
        refl_layered_pass_options,
        Vec<refl_layered_bound>,
    ) {
        let d = refl_layered_pass_options_default();
        let inp = input(&self.f, &self.descs, true);
        let (scratch, _) = prepare(&inp, &d);
        (inp, d, scratch)
    }
}

use refl_status::{InsufficientSize as Short, InvalidArgument as Bad, NullPointer as Null};

#[test]
fn options_out_of_range_are_refused_naming_the_options() {
    let e = ErrorSetup::new();
    let (inp, d, scratch) = e.c();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    for bad in [
        refl_layered_pass_options {
            t_max: f32::NAN,
            ..d
        },
        refl_layered_pass_options { t_min: -1.0, ..d },
        refl_layered_pass_options {
            start_pixels: -1.0,
            ..d
        },
        refl_layered_pass_options {
            trace: refl_layered_options {
                step_texels: 0.0,
                ..d.trace
            },
            ..d
        },
    ] {
        refused(Bad, &inp, &bad, &scratch, all, n, false);
        assert!(last_error().contains("`options`"), "{}", last_error());
        prepare_refused(Bad, &inp, &bad, 2);
    }
}

#[test]
fn null_arguments_are_refused_before_any_size_or_input_error() {
    let e = ErrorSetup::new();
    let (inp, d, scratch) = e.c();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    refused(Null, core::ptr::null(), &d, &scratch, all, n, false);
    refused(Null, &inp, core::ptr::null(), &scratch, all, n, false);
    // SAFETY: NULL scratch with maps.
    let s = unsafe { refl_layered_pass_prepare(core::ptr::null_mut(), 2, &inp, &d) };
    assert_eq!(s, Null);
    // A NULL scratch with maps is NULL_POINTER before any size or input
    // error (finding F25: with a length of 0 it read as too short).
    let mut bad_g = inp;
    bad_g.gbuffer.depth.camera.width += 1;
    // SAFETY: NULL scratch, the rest valid (or a G-buffer of another size).
    let s = unsafe { refl_layered_pass_prepare(core::ptr::null_mut(), 0, &bad_g, &d) };
    assert_eq!(s, Null, "{}", last_error());
    assert!(last_error().contains("`scratch`"), "{}", last_error());
    let mut out = vec![refl_layered_pass_texel::default(); n];
    let mut st = refl_layered_pass_stats::default();
    for g in [&inp, &bad_g] {
        // SAFETY: valid outputs, NULL scratch.
        let s = unsafe {
            refl_layered_trace_rows(
                &mut st,
                out.as_mut_ptr(),
                n,
                no_color(),
                core::ptr::null_mut(),
                0,
                g,
                &d,
                core::ptr::null(),
                0,
                all,
            )
        };
        assert_eq!(s, Null, "{}", last_error());
        assert!(last_error().contains("`scratch`"), "{}", last_error());
    }
    let rays = [refl_host_ray::default(); 2];
    // out_len 0 < 2 rays.
    let s = host_rays_without_scratch(&mut st, &mut out[..0], &inp, &d, 0, &rays);
    assert_eq!(s, Null, "{}", last_error());
    assert!(out.iter().all(|t| *t == refl_layered_pass_texel::default()));
}

/// `refl_layered_trace_host_rays` of `rays` into `out` (its length as
/// `out_len`), no color, no host list, a NULL scratch of `scratch_len`.
fn host_rays_without_scratch(
    st: &mut refl_layered_pass_stats,
    out: &mut [refl_layered_pass_texel],
    inp: &refl_layered_pass_input,
    d: &refl_layered_pass_options,
    scratch_len: usize,
    rays: &[refl_host_ray],
) -> refl_status {
    // SAFETY: `out` and `rays` valid for their lengths, NULL optional
    // outputs of length 0, NULL scratch.
    unsafe {
        refl_layered_trace_host_rays(
            st,
            out.as_mut_ptr(),
            out.len(),
            core::ptr::null_mut(),
            0,
            core::ptr::null_mut(),
            0,
            inp,
            d,
            core::ptr::null(),
            scratch_len,
            rays.as_ptr(),
            rays.len(),
        )
    }
}

/// A valid listed ray at pixel (3, 4): from (0, 1, 5) down -z, `[0, t_max]`.
fn listed_ray(t_max: f32) -> refl_host_ray {
    refl_host_ray {
        x: 3,
        y: 4,
        origin: refl_vec3 {
            x: 0.0,
            y: 1.0,
            z: 5.0,
        },
        dir: refl_vec3 {
            x: 0.0,
            y: 0.0,
            z: -1.0,
        },
        t_min: 0.0,
        t_max,
        status: 0,
    }
}

#[test]
fn without_maps_a_null_scratch_of_any_length_is_empty() {
    // Finding F29: with no maps the scratch is not read, and the header
    // allows it NULL; a NULL scratch with a non-zero `scratch_len` was
    // refused as NULL_POINTER by both trace calls.
    let e = ErrorSetup::new();
    let (inp, d, _) = e.c();
    let no_maps = refl_layered_pass_input {
        maps: core::ptr::null(),
        maps_len: 0,
        ..inp
    };
    let n = (W * H) as usize;
    let all = refl_row_range { begin: 0, end: H };
    for len in [0usize, 3, usize::MAX] {
        let mut out = vec![refl_layered_pass_texel::default(); n];
        let mut st = refl_layered_pass_stats::default();
        // SAFETY: valid outputs, no maps, NULL scratch.
        let s = unsafe {
            refl_layered_trace_rows(
                &mut st,
                out.as_mut_ptr(),
                n,
                no_color(),
                core::ptr::null_mut(),
                0,
                &no_maps,
                &d,
                core::ptr::null(),
                len,
                all,
            )
        };
        assert_eq!(s, refl_status::Ok, "scratch_len {len}: {}", last_error());
        let rays = [listed_ray(10.0); 2];
        let mut ray_out = vec![refl_layered_pass_texel::default(); 2];
        let s = host_rays_without_scratch(&mut st, &mut ray_out, &no_maps, &d, len, &rays);
        assert_eq!(s, refl_status::Ok, "scratch_len {len}: {}", last_error());
    }
}

#[test]
fn bad_sizes_and_a_color_output_without_payload_colors_are_refused() {
    let e = ErrorSetup::new();
    let (inp, d, scratch) = e.c();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    // Sizes: out, rows, scratch.
    refused(Short, &inp, &d, &scratch, all, n - 1, false);
    refused(
        Bad,
        &inp,
        &d,
        &scratch,
        refl_row_range {
            begin: 2,
            end: H + 1,
        },
        n,
        false,
    );
    refused(
        Bad,
        &inp,
        &d,
        &scratch,
        refl_row_range { begin: 3, end: 2 },
        n,
        false,
    );
    refused(Short, &inp, &d, &scratch[..1], all, n, false);
    assert!(last_error().contains("`scratch_len`"), "{}", last_error());
    prepare_refused(Short, &inp, &d, 1);
    // A color output without payload colors.
    refused(Bad, &inp, &d, &scratch, all, n, true);
    assert!(last_error().contains("`color`"), "{}", last_error());
}

#[test]
fn a_scratch_prepared_for_other_maps_is_refused() {
    let e = ErrorSetup::new();
    let (_, d, scratch) = e.c();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    let (f, descs) = (&e.f, e.descs);
    // Swapped, a map moved.
    let swapped = [descs[1], descs[0]];
    let inp_swapped = refl_layered_pass_input {
        map_ids: [5u32, 1].as_ptr(),
        ..input(f, &swapped, true)
    };
    refused(Bad, &inp_swapped, &d, &scratch, all, n, false);
    assert!(last_error().contains("`scratch`"), "{}", last_error());
    let mut moved = descs;
    moved[1].grid.world_from_local.m[13] += 0.25;
    refused(Bad, &input(f, &moved, true), &d, &scratch, all, n, false);
}

#[test]
fn bad_maps_are_refused_untouched() {
    let e = ErrorSetup::new();
    let (inp, d, scratch) = e.c();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    let (f, descs) = (&e.f, e.descs);
    // A short buffer, a NULL buffer, another grid than the stamp's,
    // a non-affine placement, a NULL map list with maps.
    let mut m = descs;
    m[0].bounds_len -= 1;
    refused(Short, &input(f, &m, true), &d, &scratch, all, n, false);
    prepare_refused(Short, &input(f, &m, true), &d, 2);
    let mut m = descs;
    m[1].payload = core::ptr::null();
    refused(Null, &input(f, &m, true), &d, &scratch, all, n, false);
    let mut m = descs;
    m[0].grid.min.x -= 0.1;
    refused(Bad, &input(f, &m, true), &d, &scratch, all, n, false);
    assert!(
        last_error().contains("input.maps[0]") || last_error().contains("`map`"),
        "{}",
        last_error()
    );
    let mut m = descs;
    m[1].grid.world_from_local.m[3] = 0.5;
    refused(Bad, &input(f, &m, true), &d, &scratch, all, n, false);
    let null_maps = refl_layered_pass_input {
        maps: core::ptr::null(),
        ..inp
    };
    refused(Null, &null_maps, &d, &scratch, all, n, false);
}

#[test]
fn bad_ids_and_gbuffer_images_are_refused_untouched() {
    let e = ErrorSetup::new();
    let (inp, d, scratch) = e.c();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    // Ids of another size; too few map ids; NULL map ids.
    let wrong_ids = refl_layered_pass_input {
        ids: refl_image_u32 {
            width: W - 1,
            ..inp.ids
        },
        ..inp
    };
    refused(Bad, &wrong_ids, &d, &scratch, all, n, false);
    assert!(last_error().contains("`input.ids`"), "{}", last_error());
    let few = refl_layered_pass_input {
        map_ids_len: 1,
        ..inp
    };
    refused(Short, &few, &d, &scratch, all, n, false);
    prepare_refused(Short, &few, &d, 2);
    let null_ids = refl_layered_pass_input {
        map_ids: core::ptr::null(),
        ..inp
    };
    refused(Null, &null_ids, &d, &scratch, all, n, false);
    // A G-buffer image not of the camera's size, a NaN camera.
    let mut small = inp;
    small.gbuffer.normals.width = W - 1;
    refused(Bad, &small, &d, &scratch, all, n, false);
    prepare_refused(Bad, &small, &d, 2);
    let mut nan = inp;
    nan.gbuffer.depth.camera.fov_y = f32::NAN;
    refused(Bad, &nan, &d, &scratch, all, n, false);
}

/// Outputs overlapping inputs: out over the scratch, over a map buffer.
#[test]
fn outputs_over_their_inputs_are_refused_untouched() {
    let e = ErrorSetup::new();
    let (inp, d, scratch) = e.c();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    let (f, descs, owned) = (&e.f, e.descs, &e.owned);
    let mut texels = vec![refl_layered_pass_texel::default(); n];
    let mut stats = refl_layered_pass_stats::default();
    // The scratch's last three records hold one host ray.
    let mut sc = scratch.clone();
    sc.resize(5, refl_layered_bound::default());
    let host_in_scratch = sc[2..].as_mut_ptr().cast::<refl_host_ray>();
    // SAFETY: valid pointers; the host list aliases the scratch on purpose.
    let s = unsafe {
        refl_layered_trace_rows(
            &mut stats,
            texels.as_mut_ptr(),
            n,
            no_color(),
            host_in_scratch,
            1,
            &inp,
            &d,
            sc.as_ptr(),
            sc.len(),
            all,
        )
    };
    assert_eq!(s, Bad);
    assert_eq!(stats, refl_layered_pass_stats::default());
    let mut buf = owned[0].depth.clone();
    let mut aliased = descs;
    aliased[0].depth = buf.as_ptr();
    let ainp = input(f, &aliased, true);
    let mut ascratch = vec![refl_layered_bound::default(); 2];
    // SAFETY: valid pointers; the scratch aliases a map buffer on purpose.
    let s = unsafe { refl_layered_pass_prepare(buf.as_mut_ptr().cast(), 2, &ainp, &d) };
    assert_eq!(s, Bad);
    assert!(buf
        .iter()
        .zip(&owned[0].depth)
        .all(|(a, b)| a.to_bits() == b.to_bits()));
    // SAFETY: valid pointers.
    assert_eq!(
        unsafe { refl_layered_pass_prepare(ascratch.as_mut_ptr(), 2, &ainp, &d) },
        refl_status::Ok
    );
}

#[test]
fn bad_listed_rays_are_refused_untouched() {
    let e = ErrorSetup::new();
    let (inp, d, scratch) = e.c();
    // A NaN ray, a non-unit one, t_max not above t_min, a
    // short out, color without payload colors; nothing written.
    let good = listed_ray(f32::INFINITY);
    let bad_rays = [
        refl_host_ray {
            origin: refl_vec3 {
                x: f32::NAN,
                ..good.origin
            },
            ..good
        },
        refl_host_ray {
            dir: refl_vec3 {
                z: -1.2,
                ..good.dir
            },
            ..good
        },
        refl_host_ray {
            t_min: 2.0,
            t_max: 2.0,
            ..good
        },
        refl_host_ray {
            t_min: -1.0,
            ..good
        },
    ];
    let texel = refl_layered_pass_texel {
        status: 99,
        ..Default::default()
    };
    let listed = |want: refl_status, rays: &[refl_host_ray], out_len: usize, color: bool| {
        let mut out = vec![texel; 4];
        let mut colors = vec![
            refl_vec3 {
                x: 5.0,
                y: 5.0,
                z: 5.0
            };
            4
        ];
        let mut host = vec![
            refl_host_ray {
                x: 77,
                ..Default::default()
            };
            4
        ];
        let mut st = refl_layered_pass_stats {
            traced: 55,
            ..Default::default()
        };
        let (cp, cl) = if color {
            (colors.as_mut_ptr(), 4)
        } else {
            (core::ptr::null_mut(), 0)
        };
        let (s, allocs) = counted(|| {
            // SAFETY: valid buffers of the stated lengths.
            unsafe {
                refl_layered_trace_host_rays(
                    &mut st,
                    out.as_mut_ptr(),
                    out_len,
                    cp,
                    cl,
                    host.as_mut_ptr(),
                    4,
                    &inp,
                    &d,
                    scratch.as_ptr(),
                    scratch.len(),
                    rays.as_ptr(),
                    rays.len(),
                )
            }
        });
        assert_eq!((s, allocs), (want, 0), "{}", last_error());
        if want != refl_status::Ok {
            assert!(out.iter().all(|t| *t == texel));
            assert!(colors.iter().all(|c| c.x == 5.0));
            assert!(host.iter().all(|h| h.x == 77));
            assert_eq!(st.traced, 55);
        }
    };
    listed(refl_status::Ok, &[good, good], 2, false);
    for b in bad_rays {
        listed(Bad, &[good, b], 2, false);
        assert!(last_error().contains("`rays`"), "{}", last_error());
    }
    listed(Short, &[good, good], 1, false);
    listed(Bad, &[good], 1, true);
}

/// Regions over the frame: pixel `i` has region `i % 9`, region 8 is
/// `REFL_LAYERED_NO_REGION`; the masks of regions 0..8 drop maps in every
/// combination, so the C pass's region rule is held against refl-core's.
fn test_regions() -> (Vec<u32>, [u64; 8]) {
    let regions = (0..W * H)
        .map(|i| {
            if i % 9 == 8 {
                REFL_LAYERED_NO_REGION
            } else {
                i % 9
            }
        })
        .collect();
    (regions, [0, 1, 2, 3, 3, 2, 1, 0])
}

#[test]
fn c_pass_with_regions_equals_the_rust_pass_bit_for_bit() {
    let owned = maps();
    let views = [owned[0].map(), owned[1].map()];
    let descs = [owned[0].c(), owned[1].c()];
    let f = render(DepthConvention::Linear);
    let (regions, masks) = test_regions();
    let mut skipped = 0;
    for o in option_sets() {
        let oc: refl_layered_pass_options = o.into();
        for ids in [false, true] {
            let inp = with_regions(&input(&f, &descs, ids), &regions, &masks);
            let (scratch, _) = prepare(&inp, &oc);
            let (s, c, allocs) = c_run(&inp, &oc, &scratch, o.payload_color);
            assert_eq!(s, refl_status::Ok, "{}", last_error());
            assert_eq!(allocs, 0);
            let mut rb = vec![LayeredBound::default(); 2];
            try_prepare_layered_pass(&mut rb, &f.gbuffer(false), &views[..], &o).unwrap();
            let pass = rust_pass(&f, &views, &rb, o, ids)
                .try_with_regions(ImageView::try_new(&regions, W, H, W).unwrap(), &masks)
                .unwrap();
            let np = (W * H) as usize;
            let mut out = vec![LayeredPassTexel::default(); np];
            let mut host = vec![LayeredHostRay::default(); np];
            let st = pass
                .try_run(
                    &mut ImageViewMut::try_new(&mut out, W, H, W).unwrap(),
                    None,
                    &mut host,
                )
                .unwrap();
            assert_eq!(c.stats, st.into());
            assert_eq!(c.texels.len(), np);
            for (i, (a, b)) in c.texels.iter().zip(&out).enumerate() {
                assert_eq!(texel_bits(a), texel_bits(&(*b).into()), "{i}");
            }
            skipped += c.stats.prr_skipped;
        }
    }
    assert!(skipped > 1000, "{skipped}");
}

/// Flat and tilted reflector triangles around the maps.
fn prr_triangles() -> Vec<refl_layered_prr_triangle> {
    let v = |x: f32, y: f32, z: f32| refl_vec3 { x, y, z };
    (0..40)
        .map(|k| {
            let (x, z) = ((k % 8) as f32 - 4.0, -((k / 8) as f32) * 1.5);
            let corners = [v(x, 0.0, z), v(x + 1.0, 0.0, z), v(x, 0.2, z - 1.0)];
            let t = PrrTriangle::flat(corners.map(Vec3::from));
            let n = t.normals[0];
            let tilt = if k % 3 == 0 { 0.3 } else { 0.0 };
            refl_layered_prr_triangle {
                corners,
                normals: [
                    v(n[0] + tilt, n[1], n[2]),
                    v(n[0], n[1] + tilt, n[2]),
                    v(n[0], n[1], n[2] - tilt),
                ],
            }
        })
        .collect()
}

#[test]
fn prr_masks_equal_refl_core_without_allocating() {
    let e = ErrorSetup::new();
    let (_, _, scratch) = e.c();
    let tris = prr_triangles();
    let eye = refl_vec3 {
        x: 0.3,
        y: 1.8,
        z: 4.0,
    };
    let mut masks = vec![u64::MAX; tris.len() + 1];
    let mut st = refl_layered_prr_stats::default();
    // SAFETY: valid buffers of the stated lengths.
    let (s, allocs) = counted(|| unsafe {
        refl_layered_prr_masks(
            &mut st,
            masks.as_mut_ptr(),
            tris.len(),
            tris.as_ptr(),
            tris.len(),
            eye,
            scratch.as_ptr(),
            scratch.len(),
        )
    });
    assert_eq!((s, allocs), (refl_status::Ok, 0), "{}", last_error());
    let rt: Vec<PrrTriangle> = tris
        .iter()
        .map(|t| PrrTriangle {
            corners: t.corners.map(|c| [c.x, c.y, c.z]),
            normals: t.normals.map(|c| [c.x, c.y, c.z]),
        })
        .collect();
    let rb: Vec<LayeredBound> = scratch
        .iter()
        .map(|b| LayeredBound {
            center: [b.center.x, b.center.y, b.center.z],
            radius: b.radius,
            key: b.key,
        })
        .collect();
    let mut want = vec![0u64; tris.len()];
    let ws = try_prr_masks(&mut want, &rt, eye.into(), &rb).unwrap();
    assert_eq!(masks[..tris.len()], want[..]);
    assert_eq!(masks[tris.len()], u64::MAX);
    assert_eq!(st, ws.into());
    assert!(ws.may_reflect > 0 && ws.may_reflect < ws.pairs, "{ws:?}");
}

#[test]
fn bad_regions_and_prr_masks_are_refused_untouched() {
    let e = ErrorSetup::new();
    let (inp, d, scratch) = e.c();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    let (mut regions, masks) = test_regions();
    // Regions of another size.
    let mut wrong = with_regions(&inp, &regions, &masks);
    wrong.regions.width = W - 1;
    refused(Bad, &wrong, &d, &scratch, all, n, false);
    assert!(last_error().contains("`input.regions`"), "{}", last_error());
    prepare_refused(Bad, &wrong, &d, 2);
    // NULL masks with a length.
    let null_masks = refl_layered_pass_input {
        region_masks: core::ptr::null(),
        ..with_regions(&inp, &regions, &masks)
    };
    refused(Null, &null_masks, &d, &scratch, all, n, false);
    // A region id out of range.
    regions[n - 1] = masks.len() as u32;
    let out_of_range = with_regions(&inp, &regions, &masks);
    refused(Bad, &out_of_range, &d, &scratch, all, n, false);
    assert!(last_error().contains("region id"), "{}", last_error());
    regions[n - 1] = REFL_LAYERED_NO_REGION;
    // More maps than bits of a word: two words per region, so the eight
    // words hold four regions.
    let many = vec![e.descs[0]; 65];
    let few_regions: Vec<u32> = regions.iter().map(|&r| r.min(3)).collect();
    let many_inp = refl_layered_pass_input {
        maps: many.as_ptr(),
        maps_len: many.len(),
        ids: refl_image_u32 {
            data: core::ptr::null(),
            ..inp.ids
        },
        ..with_regions(&inp, &few_regions, &masks)
    };
    let (many_scratch, _) = prepare(&many_inp, &d);
    let (s, _, _) = c_run(&many_inp, &d, &many_scratch, false);
    assert_eq!(s, refl_status::Ok, "{}", last_error());
    let mut five: Vec<u32> = few_regions.clone();
    five[3] = 4;
    let five_inp = refl_layered_pass_input {
        regions: refl_image_u32 {
            data: five.as_ptr(),
            ..many_inp.regions
        },
        ..many_inp
    };
    refused(Bad, &five_inp, &d, &many_scratch, all, n, false);

    // The size query.
    let mut words = 0usize;
    // SAFETY: valid pointer.
    assert_eq!(
        unsafe { refl_layered_prr_masks_len(&mut words, 10, 65) },
        refl_status::Ok
    );
    assert_eq!(words, 20);
    // SAFETY: valid pointer.
    assert_eq!(
        unsafe { refl_layered_prr_masks_len(&mut words, 10, 0) },
        refl_status::Ok
    );
    assert_eq!(words, 10);
    // SAFETY: NULL is refused.
    assert_eq!(
        unsafe { refl_layered_prr_masks_len(core::ptr::null_mut(), 10, 65) },
        Null
    );
    // SAFETY: valid pointer. (32-bit counts cannot overflow a 64-bit size_t.)
    assert_eq!(
        unsafe { refl_layered_prr_masks_len(&mut words, u32::MAX, 65) },
        refl_status::Ok
    );
    assert_eq!(words as u64, 2 * u64::from(u32::MAX));

    // The mask builder: NaN eye, short masks (one and two words per
    // triangle), NULL stats, NULL triangles; nothing written.
    let tris = prr_triangles();
    let eye = refl_vec3 {
        x: 0.3,
        y: 1.8,
        z: 4.0,
    };
    let nan = refl_vec3 { x: f32::NAN, ..eye };
    let many_scratch = vec![scratch[0]; 65];
    // (status, NULL stats, masks_len, triangles, eye, scratch)
    type Case<'a> = (
        refl_status,
        bool,
        usize,
        *const refl_layered_prr_triangle,
        refl_vec3,
        &'a [refl_layered_bound],
    );
    let cases: [Case<'_>; 5] = [
        (Bad, false, tris.len(), tris.as_ptr(), nan, &scratch),
        (Short, false, tris.len() - 1, tris.as_ptr(), eye, &scratch),
        (Null, true, tris.len(), tris.as_ptr(), eye, &scratch),
        (Null, false, tris.len(), core::ptr::null(), eye, &scratch),
        (
            Short,
            false,
            2 * tris.len() - 1,
            tris.as_ptr(),
            eye,
            &many_scratch,
        ),
    ];
    for (want, null_stats, masks_len, tp, eye, sc) in cases {
        let mut out = vec![7u64; 2 * tris.len()];
        let mut st = refl_layered_prr_stats {
            regions: 55,
            ..Default::default()
        };
        let stats_ptr: *mut refl_layered_prr_stats = if null_stats {
            core::ptr::null_mut()
        } else {
            &mut st
        };
        // SAFETY: valid buffers of the stated lengths, or NULL.
        let (s, allocs) = counted(|| unsafe {
            refl_layered_prr_masks(
                stats_ptr,
                out.as_mut_ptr(),
                masks_len,
                tp,
                tris.len(),
                eye,
                sc.as_ptr(),
                sc.len(),
            )
        });
        assert_eq!(s, want, "{}", last_error());
        assert_eq!(allocs, 0);
        assert!(out.iter().all(|&m| m == 7) && st.regions == 55);
    }
}
