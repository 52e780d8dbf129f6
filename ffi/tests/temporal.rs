//! refl_temporal_*: the C filter equals refl-core's `TemporalPass` bit for
//! bit (every depth convention, with and without reflection distances and
//! a status image, the first frame without history and the next ones with
//! the history of a moved camera), row bands (two halves, and threads)
//! equal one call and leave the other rows untouched, every refusal returns
//! its documented status, names the argument in the last-error message and
//! leaves every output byte as it was, and no call allocates (the counting
//! global allocator of `tests/common`; `tests/alloc.rs` covers every
//! export).

#[path = "common/gbuffer.rs"]
mod common;

use common::{counted, moved_camera, render, render_with, Frame, Shared, H, W};
use refl::*;
use refl_core::glam::Vec3;
use refl_core::temporal::{
    History, HistoryTexel, TemporalOptions, TemporalPass, TemporalStats, TemporalStatus,
};
use refl_core::{Camera, DepthConvention, ImageView, ImageViewMut};

const N: usize = (W * H) as usize;

/// The byte every output is filled with before a call that must fail.
const SENTINEL: u8 = 0xA5;

/// One frame's inputs to the filter: reflection colors, which pixels were
/// answered, reflection distances.
struct Inputs {
    current: Vec<[f32; 3]>,
    answered: Vec<u8>,
    distance: Vec<f32>,
}

/// Inputs for frame `f`: a smooth color per surface pixel (varied by
/// `seed`), every 7th pixel failed (its color the fallback), a few answered
/// pixels with a NaN color (taken as failed), distances mostly known (some
/// sky, some unknown or NaN).
fn inputs(f: &Frame, seed: u32) -> Inputs {
    let mut inp = Inputs {
        current: vec![[0.0; 3]; N],
        answered: vec![1; N],
        distance: vec![0.0; N],
    };
    for i in 0..N {
        let (x, y) = ((i as u32 % W) as f32, (i as u32 / W) as f32);
        let s = seed as f32;
        inp.current[i] = [
            0.5 + 0.4 * (0.11 * x + 0.3 * s).sin(),
            0.5 + 0.4 * (0.07 * y - 0.2 * s).cos(),
            f.color[i][0] * 0.25 + 0.1,
        ];
        inp.distance[i] = match (i + seed as usize) % 13 {
            0 => f32::INFINITY,
            1 => 0.0,
            2 => f32::NAN,
            k => 0.5 + 0.2 * k as f32,
        };
        if (i + seed as usize) % 7 == 3 {
            inp.answered[i] = 0;
            inp.current[i] = [0.25, 0.25, 0.25];
        }
        if i % 97 == 5 {
            inp.current[i] = [f32::NAN, 0.0, 0.0];
        }
    }
    inp
}

fn img_vec3(d: &[[f32; 3]]) -> refl_image_vec3 {
    common::img_vec3(d)
}

fn img_u8(d: &[u8]) -> refl_image_u8 {
    refl_image_u8 {
        data: d.as_ptr(),
        len: d.len(),
        width: W,
        height: H,
        stride: W,
    }
}

fn u8_mut(d: &mut [u8]) -> refl_image_u8_mut {
    refl_image_u8_mut {
        data: d.as_mut_ptr(),
        len: d.len(),
        width: W,
        height: H,
        stride: W,
    }
}

fn no_u8_mut() -> refl_image_u8_mut {
    refl_image_u8_mut {
        data: core::ptr::null_mut(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    }
}

fn texels(d: &[refl_temporal_texel]) -> refl_image_temporal_texel {
    refl_image_temporal_texel {
        data: d.as_ptr(),
        len: d.len(),
        width: W,
        height: H,
        stride: W,
    }
}

fn texels_mut(d: &mut [refl_temporal_texel]) -> refl_image_temporal_texel_mut {
    refl_image_temporal_texel_mut {
        data: d.as_mut_ptr(),
        len: d.len(),
        width: W,
        height: H,
        stride: W,
    }
}

/// A history of `texels` written with `cam`.
fn history(cam: &Camera, t: &[refl_temporal_texel]) -> refl_temporal_history {
    refl_temporal_history {
        camera: cam.into(),
        texels: texels(t),
    }
}

/// No history (the first frame); the camera is ignored, here invalid.
fn no_history() -> refl_temporal_history {
    let mut camera: refl_camera = (&common::camera()).into();
    camera.fov_y = f32::NAN;
    refl_temporal_history {
        camera,
        texels: refl_image_temporal_texel {
            data: core::ptr::null(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        },
    }
}

/// A texel of sentinel bytes.
fn sentinel_texel() -> refl_temporal_texel {
    let v = f32::from_bits(u32::from_ne_bytes([SENTINEL; 4]));
    refl_temporal_texel {
        color: refl_vec3 { x: v, y: v, z: v },
        frames: v,
        normal: refl_vec3 { x: v, y: v, z: v },
        depth: v,
        distance: v,
    }
}

fn sentinel_stats() -> refl_temporal_stats {
    let v = u32::from_ne_bytes([SENTINEL; 4]);
    refl_temporal_stats {
        blended: v,
        reset: v,
        recovered: v,
        unanswered: v,
        off_screen: v,
        rejected: v,
    }
}

fn bits(t: &refl_temporal_texel) -> [u32; 9] {
    [
        t.color.x, t.color.y, t.color.z, t.frames, t.normal.x, t.normal.y, t.normal.z, t.depth,
        t.distance,
    ]
    .map(f32::to_bits)
}

fn core_bits(t: &HistoryTexel) -> [u32; 9] {
    [
        t.color[0],
        t.color[1],
        t.color[2],
        t.frames,
        t.normal[0],
        t.normal[1],
        t.normal[2],
        t.depth,
        t.distance,
    ]
    .map(f32::to_bits)
}

fn stats_tuple(s: &refl_temporal_stats) -> [u32; 6] {
    [
        s.blended,
        s.reset,
        s.recovered,
        s.unanswered,
        s.off_screen,
        s.rejected,
    ]
}

fn core_stats_tuple(s: &TemporalStats) -> [u32; 6] {
    [
        s.blended,
        s.reset,
        s.recovered,
        s.unanswered,
        s.off_screen,
        s.rejected,
    ]
}

/// What one C call writes: the next history, the statuses and the counts.
struct CRun {
    next: Vec<refl_temporal_texel>,
    status: Vec<u8>,
    stats: refl_temporal_stats,
}

/// One `refl_temporal_resolve_rows` over `rows` into outputs of sentinel
/// bytes (no status image unless `with_status`); its status, outputs and
/// allocations.
#[allow(clippy::too_many_arguments)]
fn c_run(
    g: &refl_gbuffer,
    inp: &Inputs,
    with_distance: bool,
    hist: &refl_temporal_history,
    o: &refl_temporal_options,
    with_status: bool,
    rows: refl_row_range,
) -> (refl_status, CRun, u64) {
    let mut r = CRun {
        next: vec![sentinel_texel(); N],
        status: vec![SENTINEL; N],
        stats: sentinel_stats(),
    };
    let next = texels_mut(&mut r.next);
    let status = if with_status {
        u8_mut(&mut r.status)
    } else {
        no_u8_mut()
    };
    let distance = if with_distance {
        common::img_f32(&inp.distance)
    } else {
        common::none_f32()
    };
    let (s, allocs) = counted(|| {
        // SAFETY: valid buffers of the stated lengths, outputs disjoint
        // from the inputs.
        unsafe {
            refl_temporal_resolve_rows(
                &mut r.stats,
                next,
                status,
                g,
                img_vec3(&inp.current),
                img_u8(&inp.answered),
                distance,
                hist,
                o,
                rows,
            )
        }
    });
    (s, r, allocs)
}

fn all_rows() -> refl_row_range {
    refl_row_range { begin: 0, end: H }
}

/// refl-core's filter over the whole image.
fn rust_run(
    f: &Frame,
    inp: &Inputs,
    with_distance: bool,
    hist: Option<(&Camera, &[refl_temporal_texel])>,
    o: TemporalOptions,
) -> (Vec<HistoryTexel>, Vec<u8>, TemporalStats) {
    let past: Option<Vec<HistoryTexel>> =
        hist.map(|(_, t)| t.iter().map(|&t| HistoryTexel::from(t)).collect());
    let history = hist
        .zip(past.as_ref())
        .map(|((c, _), t)| History::try_new(*c, ImageView::try_new(t, W, H, W).unwrap()).unwrap());
    let mut pass = TemporalPass::try_new(
        f.gbuffer(false),
        ImageView::try_new(&inp.current, W, H, W).unwrap(),
        ImageView::try_new(&inp.answered, W, H, W).unwrap(),
        history,
        o,
    )
    .unwrap();
    if with_distance {
        pass = pass
            .try_with_distance(ImageView::try_new(&inp.distance, W, H, W).unwrap())
            .unwrap();
    }
    let mut next = vec![HistoryTexel::default(); N];
    let mut status = vec![0u8; N];
    let stats = pass
        .try_run(
            &mut ImageViewMut::try_new(&mut next, W, H, W).unwrap(),
            Some(&mut ImageViewMut::try_new(&mut status, W, H, W).unwrap()),
        )
        .unwrap();
    (next, status, stats)
}

/// Asserts the C run equals refl-core's bit for bit.
fn assert_same(
    c: &CRun,
    with_status: bool,
    r: &(Vec<HistoryTexel>, Vec<u8>, TemporalStats),
    what: &str,
) {
    assert_eq!(
        stats_tuple(&c.stats),
        core_stats_tuple(&r.2),
        "{what}: stats"
    );
    for i in 0..N {
        assert_eq!(bits(&c.next[i]), core_bits(&r.0[i]), "{what}: texel {i}");
        if with_status {
            assert_eq!(c.status[i], r.1[i], "{what}: status {i}");
        } else {
            assert_eq!(
                c.status[i], SENTINEL,
                "{what}: status written without an image"
            );
        }
    }
}

#[test]
fn the_allocation_counter_counts() {
    let (v, n) = counted(|| Vec::<u8>::with_capacity(3));
    assert_eq!((v.capacity() >= 3, n), (true, 1));
}

#[test]
fn the_defaults_are_refl_cores() {
    let c = refl_temporal_options_default();
    assert_eq!(TemporalOptions::from(c), TemporalOptions::default());
    assert_eq!(
        (c.max_frames, c.depth_tolerance, c.normal_cos, c.recover),
        (8.0, 0.02, 0.9, true)
    );
    // The texel is refl-core's, field for field.
    let t = HistoryTexel {
        color: [1.0, 2.0, 3.0],
        frames: 4.0,
        normal: [5.0, 6.0, 7.0],
        depth: 8.0,
        distance: 9.0,
    };
    assert_eq!(HistoryTexel::from(refl_temporal_texel::from(t)), t);
    assert_eq!(core::mem::size_of::<refl_temporal_texel>(), 36);
    for (s, c) in [
        (TemporalStatus::Skipped, refl_temporal_status::Skipped),
        (TemporalStatus::Blended, refl_temporal_status::Blended),
        (TemporalStatus::Reset, refl_temporal_status::Reset),
        (TemporalStatus::Recovered, refl_temporal_status::Recovered),
        (TemporalStatus::Unanswered, refl_temporal_status::Unanswered),
    ] {
        assert_eq!(refl_temporal_status::from(s), c);
        assert_eq!(s as u32, c as u32);
    }
}

/// Three frames per depth convention: the first without history, the
/// second from a moved camera with the first's history, the third from the
/// same camera with reflection distances and other options; each equals
/// refl-core's bit for bit and allocates nothing.
#[test]
fn c_filter_equals_the_rust_filter_bit_for_bit_without_allocating() {
    let cam0 = common::camera();
    let cam1 = moved_camera();
    for conv in [
        DepthConvention::Linear,
        DepthConvention::ZeroToOne,
        DepthConvention::ReversedZ,
    ] {
        let f0 = render(conv);
        let f1 = render_with(cam1, conv);
        let (g0, g1) = (f0.gbuffer_c(false), f1.gbuffer_c(false));
        let d = refl_temporal_options_default();

        // Frame 0: no history.
        let in0 = inputs(&f0, 0);
        let (s, c0, allocs) = c_run(&g0, &in0, false, &no_history(), &d, true, all_rows());
        assert_eq!((s, allocs), (refl_status::Ok, 0), "{conv:?} frame 0");
        let r0 = rust_run(&f0, &in0, false, None, TemporalOptions::default());
        assert_same(&c0, true, &r0, "frame 0");
        assert_eq!((c0.stats.blended, c0.stats.recovered), (0, 0));
        assert!(
            c0.stats.reset > 1000 && c0.stats.unanswered > 100,
            "{:?}",
            c0.stats
        );

        // Frame 1: a moved camera, the first frame's history.
        let in1 = inputs(&f1, 1);
        let h0 = history(&cam0, &c0.next);
        for with_status in [true, false] {
            let (s, c1, allocs) = c_run(&g1, &in1, false, &h0, &d, with_status, all_rows());
            assert_eq!((s, allocs), (refl_status::Ok, 0), "{conv:?} frame 1");
            let r1 = rust_run(
                &f1,
                &in1,
                false,
                Some((&cam0, &c0.next)),
                TemporalOptions::default(),
            );
            assert_same(&c1, with_status, &r1, "frame 1");
            let st = c1.stats;
            assert!(
                st.blended > 1000 && st.recovered > 100 && st.reset > 0 && st.off_screen > 0,
                "{conv:?}: {st:?}"
            );
        }
        let (_, c1, _) = c_run(&g1, &in1, false, &h0, &d, true, all_rows());

        // Frame 2: the same camera, with distances and other options.
        let in2 = inputs(&f1, 2);
        let h1 = history(&cam1, &c1.next);
        for o in [
            refl_temporal_options {
                max_frames: 4.0,
                normal_cos: -1.0,
                ..d
            },
            refl_temporal_options {
                max_frames: f32::INFINITY,
                depth_tolerance: 0.0,
                recover: false,
                ..d
            },
            d,
        ] {
            let (s, c2, allocs) = c_run(&g1, &in2, true, &h1, &o, true, all_rows());
            assert_eq!((s, allocs), (refl_status::Ok, 0), "{conv:?} frame 2 {o:?}");
            let r2 = rust_run(&f1, &in2, true, Some((&cam1, &c1.next)), o.into());
            assert_same(&c2, true, &r2, "frame 2");
            if !o.recover {
                assert_eq!(c2.stats.recovered, 0);
            }
        }
    }
}

/// Two half bands equal one call, each leaving the other's rows (texels and
/// statuses) untouched; five bands from five threads equal one call.
#[test]
fn bands_equal_one_call_and_leave_other_rows_untouched() {
    let conv = DepthConvention::ReversedZ;
    let (f0, f1) = (render(conv), render_with(moved_camera(), conv));
    let (g0, g1) = (f0.gbuffer_c(false), f1.gbuffer_c(false));
    let d = refl_temporal_options_default();
    let (_, c0, _) = c_run(
        &g0,
        &inputs(&f0, 0),
        true,
        &no_history(),
        &d,
        true,
        all_rows(),
    );
    let in1 = inputs(&f1, 1);
    let h0 = history(&common::camera(), &c0.next);
    let (s, whole, _) = c_run(&g1, &in1, true, &h0, &d, true, all_rows());
    assert_eq!(s, refl_status::Ok);

    for k in [1, 17, H / 2, H - 1] {
        let mut next = vec![sentinel_texel(); N];
        let mut status = vec![SENTINEL; N];
        let mut sum = [0u32; 6];
        for (b, band) in [
            refl_row_range { begin: 0, end: k },
            refl_row_range { begin: k, end: H },
        ]
        .into_iter()
        .enumerate()
        {
            let mut st = refl_temporal_stats::default();
            // SAFETY: valid buffers; outputs disjoint from the inputs.
            let s = unsafe {
                refl_temporal_resolve_rows(
                    &mut st,
                    texels_mut(&mut next),
                    u8_mut(&mut status),
                    &g1,
                    img_vec3(&in1.current),
                    img_u8(&in1.answered),
                    common::img_f32(&in1.distance),
                    &h0,
                    &d,
                    band,
                )
            };
            assert_eq!(s, refl_status::Ok);
            for (a, v) in sum.iter_mut().zip(stats_tuple(&st)) {
                *a += v;
            }
            if b == 0 {
                // The rows past the first band are still the sentinels.
                let split = (k * W) as usize;
                assert!(next[split..]
                    .iter()
                    .all(|t| bits(t) == bits(&sentinel_texel())));
                assert!(status[split..].iter().all(|&v| v == SENTINEL));
                assert!(next[..split]
                    .iter()
                    .all(|t| bits(t) != bits(&sentinel_texel())));
            }
        }
        assert_eq!(sum, stats_tuple(&whole.stats), "band at {k}");
        for (i, (t, w)) in next.iter().zip(&whole.next).enumerate() {
            assert_eq!(bits(t), bits(w), "band at {k}, texel {i}");
        }
        assert_eq!(status, whole.status);
    }

    // Five bands from five threads into one image.
    let mut next = vec![sentinel_texel(); N];
    let mut status = vec![SENTINEL; N];
    let outs = Shared((texels_mut(&mut next), u8_mut(&mut status)));
    let ins = Shared((g1, h0));
    let bands = 5;
    let sums: Vec<[u32; 6]> = std::thread::scope(|s| {
        let hs: Vec<_> = (0..bands)
            .map(|b| {
                let (outs, ins, in1) = (&outs, &ins, &in1);
                s.spawn(move || {
                    let mut rows = refl_row_range::default();
                    // SAFETY: valid pointer.
                    let s = unsafe { refl_image_row_band(&mut rows, H, b, bands) };
                    assert_eq!(s, refl_status::Ok);
                    let (next, status) = *outs.get();
                    let (g, h) = ins.get();
                    let mut st = refl_temporal_stats::default();
                    // SAFETY: valid buffers; each thread writes its own rows.
                    let s = unsafe {
                        refl_temporal_resolve_rows(
                            &mut st,
                            next,
                            status,
                            g,
                            img_vec3(&in1.current),
                            img_u8(&in1.answered),
                            common::img_f32(&in1.distance),
                            h,
                            &d,
                            rows,
                        )
                    };
                    assert_eq!(s, refl_status::Ok);
                    stats_tuple(&st)
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let total = sums.iter().fold([0u32; 6], |mut a, s| {
        for (x, y) in a.iter_mut().zip(s) {
            *x += y;
        }
        a
    });
    assert_eq!(total, stats_tuple(&whole.stats));
    for (i, (t, w)) in next.iter().zip(&whole.next).enumerate() {
        assert_eq!(bits(t), bits(w), "threads, texel {i}");
    }
    assert_eq!(status, whole.status);
}

/// The arguments of one call, to be broken one at a time.
#[derive(Clone, Copy)]
struct Args {
    out_stats: *mut refl_temporal_stats,
    next: refl_image_temporal_texel_mut,
    status: refl_image_u8_mut,
    gbuffer: *const refl_gbuffer,
    current: refl_image_vec3,
    answered: refl_image_u8,
    distance: refl_image_f32,
    history: *const refl_temporal_history,
    options: *const refl_temporal_options,
    rows: refl_row_range,
}

impl Args {
    /// # Safety
    /// The pointers as `refl_temporal_resolve_rows` needs them.
    unsafe fn call(&self) -> refl_status {
        // SAFETY: forwarded contract.
        unsafe {
            refl_temporal_resolve_rows(
                self.out_stats,
                self.next,
                self.status,
                self.gbuffer,
                self.current,
                self.answered,
                self.distance,
                self.history,
                self.options,
                self.rows,
            )
        }
    }
}

/// The current last-error message.
fn last_error() -> String {
    with_last_error_message(|m| m.to_owned())
}

/// The frame and buffers of the refusal tests: a valid call (checked) whose
/// outputs are sentinel bytes, and room to break it.
struct Refusals {
    g: refl_gbuffer,
    inp: Inputs,
    past: Vec<refl_temporal_texel>,
    hist: refl_temporal_history,
    options: refl_temporal_options,
    next: Vec<refl_temporal_texel>,
    status: Vec<u8>,
    stats: refl_temporal_stats,
    // Keeps the G-buffer's images alive.
    _frame: Frame,
}

impl Refusals {
    fn new() -> Box<Self> {
        let f0 = render(DepthConvention::ZeroToOne);
        let f = render_with(moved_camera(), DepthConvention::ZeroToOne);
        let g0 = f0.gbuffer_c(false);
        let d = refl_temporal_options_default();
        let (_, c0, _) = c_run(
            &g0,
            &inputs(&f0, 0),
            false,
            &no_history(),
            &d,
            false,
            all_rows(),
        );
        let mut r = Box::new(Refusals {
            g: f.gbuffer_c(false),
            inp: inputs(&f, 1),
            past: c0.next,
            hist: no_history(),
            options: d,
            next: vec![sentinel_texel(); N],
            status: vec![SENTINEL; N],
            stats: sentinel_stats(),
            _frame: f,
        });
        r.hist = history(&common::camera(), &r.past);
        // The unbroken call succeeds.
        let a = r.args();
        // SAFETY: valid buffers.
        assert_eq!(unsafe { a.call() }, refl_status::Ok, "{}", last_error());
        r.reset();
        r
    }

    fn reset(&mut self) {
        self.next.fill(sentinel_texel());
        self.status.fill(SENTINEL);
        self.stats = sentinel_stats();
    }

    fn args(&mut self) -> Args {
        Args {
            out_stats: &mut self.stats,
            next: texels_mut(&mut self.next),
            status: u8_mut(&mut self.status),
            gbuffer: &self.g,
            current: img_vec3(&self.inp.current),
            answered: img_u8(&self.inp.answered),
            distance: common::img_f32(&self.inp.distance),
            history: &self.hist,
            options: &self.options,
            rows: all_rows(),
        }
    }

    /// Calls `a` (outputs of sentinel bytes): status `want`, a last-error
    /// message naming the function and `name`, no output byte written, no
    /// allocation.
    #[track_caller]
    fn refused(&mut self, want: refl_status, name: &str, a: Args) {
        self.reset();
        // SAFETY: the arguments point to live buffers or are broken on
        // purpose (NULL, misaligned, short lengths within the buffers).
        let (s, allocs) = counted(|| unsafe { a.call() });
        let msg = last_error();
        assert_eq!(s, want, "{name}: {msg}");
        assert_eq!(allocs, 0, "{name}: allocations on the error path");
        assert!(
            msg.starts_with("refl_temporal_resolve_rows: ") && msg.contains(&format!("`{name}")),
            "{name}: last error {msg:?}"
        );
        let sentinel = bits(&sentinel_texel());
        assert!(
            self.next.iter().all(|t| bits(t) == sentinel),
            "{name}: next written"
        );
        assert!(
            self.status.iter().all(|&v| v == SENTINEL),
            "{name}: status written"
        );
        assert_eq!(self.stats, sentinel_stats(), "{name}: stats written");
    }
}

#[test]
fn null_pointers_are_refused_naming_them_untouched() {
    let mut r = Refusals::new();
    let null = refl_status::NullPointer;
    let a = r.args();
    r.refused(
        null,
        "out_stats",
        Args {
            out_stats: core::ptr::null_mut(),
            ..a
        },
    );
    let mut b = a;
    b.next.data = core::ptr::null_mut();
    r.refused(null, "next.data", b);
    r.refused(
        null,
        "gbuffer",
        Args {
            gbuffer: core::ptr::null(),
            ..a
        },
    );
    let mut b = a;
    b.current.data = core::ptr::null();
    r.refused(null, "current.data", b);
    let mut b = a;
    b.answered.data = core::ptr::null();
    r.refused(null, "answered.data", b);
    r.refused(
        null,
        "history",
        Args {
            history: core::ptr::null(),
            ..a
        },
    );
    r.refused(
        null,
        "options",
        Args {
            options: core::ptr::null(),
            ..a
        },
    );
    // A NULL required G-buffer image, reported before a short one.
    let mut g = r.g;
    g.normals.data = core::ptr::null();
    g.depth.depth.len -= 1;
    r.refused(null, "gbuffer.normals.data", Args { gbuffer: &g, ..a });
    // A NULL required pointer before a short output.
    let mut b = a;
    b.current.data = core::ptr::null();
    b.next.len -= 1;
    r.refused(null, "current.data", b);
    // The optional images may be NULL, whatever their other fields say.
    let mut b = a;
    b.status = refl_image_u8_mut {
        data: core::ptr::null_mut(),
        len: 3,
        width: 1,
        height: 9,
        stride: 0,
    };
    b.distance = refl_image_f32 {
        data: core::ptr::null(),
        len: 7,
        width: 0,
        height: 2,
        stride: 1,
    };
    // SAFETY: valid buffers.
    assert_eq!(unsafe { b.call() }, refl_status::Ok, "{}", last_error());
}

#[test]
fn options_out_of_range_are_refused_naming_the_field_untouched() {
    let mut r = Refusals::new();
    let d = refl_temporal_options_default();
    let inv = refl_status::InvalidArgument;
    for (o, field) in [
        (
            refl_temporal_options {
                max_frames: f32::NAN,
                ..d
            },
            "options.max_frames",
        ),
        (
            refl_temporal_options {
                max_frames: 0.5,
                ..d
            },
            "options.max_frames",
        ),
        (
            refl_temporal_options {
                max_frames: f32::NEG_INFINITY,
                ..d
            },
            "options.max_frames",
        ),
        (
            refl_temporal_options {
                depth_tolerance: f32::NAN,
                ..d
            },
            "options.depth_tolerance",
        ),
        (
            refl_temporal_options {
                depth_tolerance: -0.01,
                ..d
            },
            "options.depth_tolerance",
        ),
        (
            refl_temporal_options {
                depth_tolerance: f32::INFINITY,
                ..d
            },
            "options.depth_tolerance",
        ),
        (
            refl_temporal_options {
                normal_cos: f32::NAN,
                ..d
            },
            "options.normal_cos",
        ),
        (
            refl_temporal_options {
                normal_cos: 1.5,
                ..d
            },
            "options.normal_cos",
        ),
        (
            refl_temporal_options {
                normal_cos: f32::NEG_INFINITY,
                ..d
            },
            "options.normal_cos",
        ),
    ] {
        let a = r.args();
        r.refused(inv, field, Args { options: &o, ..a });
    }
    // The ends of the ranges are accepted.
    for o in [
        refl_temporal_options {
            max_frames: 1.0,
            depth_tolerance: 0.0,
            normal_cos: -1.0,
            recover: false,
            clamp_history: false,
        },
        refl_temporal_options {
            max_frames: f32::INFINITY,
            depth_tolerance: f32::MAX,
            normal_cos: 1.0,
            recover: true,
            clamp_history: true,
        },
    ] {
        let a = r.args();
        // SAFETY: valid buffers.
        let s = unsafe { Args { options: &o, ..a }.call() };
        assert_eq!(s, refl_status::Ok, "{o:?}: {}", last_error());
    }
}

#[test]
fn bad_rows_sizes_and_descriptors_are_refused_naming_them_untouched() {
    let mut r = Refusals::new();
    let inv = refl_status::InvalidArgument;
    let short = refl_status::InsufficientSize;
    let a = r.args();
    for rows in [
        refl_row_range { begin: 3, end: 2 },
        refl_row_range { begin: 4, end: 4 },
        refl_row_range {
            begin: 0,
            end: H + 1,
        },
        refl_row_range {
            begin: H,
            end: u32::MAX,
        },
    ] {
        r.refused(inv, "rows", Args { rows, ..a });
    }
    // Each image: another size, a short buffer.
    let mut b = a;
    b.current.height = H - 1;
    r.refused(inv, "current", b);
    let mut b = a;
    b.current.len -= 1;
    r.refused(short, "current.len", b);
    let mut b = a;
    b.answered.width = W - 1;
    r.refused(inv, "answered", b);
    let mut b = a;
    b.answered.len = 0;
    r.refused(short, "answered.len", b);
    let mut b = a;
    b.distance.width = W / 2;
    b.distance.stride = W / 2;
    r.refused(inv, "distance", b);
    let mut b = a;
    b.distance.len -= 1;
    r.refused(short, "distance.len", b);
    let mut b = a;
    b.next.height = H / 2;
    r.refused(inv, "next", b);
    let mut b = a;
    b.next.len -= 1;
    r.refused(short, "next.len", b);
    let mut b = a;
    b.next.stride = W - 1;
    r.refused(inv, "next", b);
    let mut b = a;
    b.status.width = W + 1;
    b.status.stride = W + 1;
    r.refused(inv, "status", b);
    let mut b = a;
    b.status.len -= 1;
    r.refused(short, "status.len", b);
    let mut b = a;
    b.current.stride = 0;
    r.refused(inv, "current", b);
    // A G-buffer field.
    let mut g = r.g;
    g.normal_space = 7;
    r.refused(inv, "gbuffer.normal_space", Args { gbuffer: &g, ..a });
}

/// A history must have the G-buffer's size and its texels their camera's:
/// a history of another size is refused (never a frame of misses), one of
/// another camera of the same size is the re-projection itself.
#[test]
fn a_history_of_another_size_or_an_invalid_camera_is_refused_untouched() {
    let mut r = Refusals::new();
    let inv = refl_status::InvalidArgument;
    let a = r.args();
    // Texels not of their camera's size.
    let mut h = r.hist;
    h.texels.height = H - 1;
    r.refused(inv, "history.texels", Args { history: &h, ..a });
    // Texels of their camera's size, not the G-buffer's.
    let small_cam = Camera::try_look_at(
        Vec3::new(0.3, 2.0, 5.5),
        Vec3::new(0.0, 0.6, 0.0),
        Vec3::Y,
        1.0,
        0.1,
        50.0,
        W,
        H / 2,
    )
    .unwrap();
    let mut h = r.hist;
    h.camera = (&small_cam).into();
    h.texels.height = H / 2;
    r.refused(inv, "history", Args { history: &h, ..a });
    // An invalid camera.
    let mut h = r.hist;
    h.camera.fov_y = f32::NAN;
    r.refused(inv, "history.camera", Args { history: &h, ..a });
    let mut h = r.hist;
    h.camera.view.m[1] += 0.1;
    r.refused(
        refl_status::DegenerateGeometry,
        "history.camera",
        Args { history: &h, ..a },
    );
    // A short buffer, a misaligned one.
    let mut h = r.hist;
    h.texels.len -= 1;
    r.refused(
        refl_status::InsufficientSize,
        "history.texels.len",
        Args { history: &h, ..a },
    );
    let raw = vec![0u8; N * 36 + 8];
    let mut h = r.hist;
    // SAFETY: within `raw`; refused before it is read.
    h.texels.data = unsafe { raw.as_ptr().add(1) }.cast();
    r.refused(inv, "history.texels", Args { history: &h, ..a });
    // Another camera of the same size: accepted.
    let mut h = r.hist;
    h.camera = (&moved_camera()).into();
    // SAFETY: valid buffers.
    let s = unsafe { Args { history: &h, ..a }.call() };
    assert_eq!(s, refl_status::Ok, "{}", last_error());
}

#[test]
fn misaligned_outputs_are_refused_untouched() {
    let mut r = Refusals::new();
    let inv = refl_status::InvalidArgument;
    let a = r.args();
    let mut raw = vec![SENTINEL; N * 36 + 8];
    let mut b = a;
    // SAFETY: within `raw`.
    b.next.data = unsafe { raw.as_mut_ptr().add(2) }.cast();
    r.refused(inv, "next.data", b);
    assert!(raw.iter().all(|&v| v == SENTINEL));
    let mut st = [SENTINEL; 32];
    let b = Args {
        // SAFETY: within `st`.
        out_stats: unsafe { st.as_mut_ptr().add(1) }.cast(),
        ..a
    };
    r.refused(inv, "out_stats", b);
    assert!(st.iter().all(|&v| v == SENTINEL));
}

/// Outputs overlapping each other or an input are refused (the filter
/// reads the history while it writes the next one: they must be two
/// buffers), naming both.
#[test]
fn overlapping_outputs_are_refused_naming_them_untouched() {
    let mut r = Refusals::new();
    let inv = refl_status::InvalidArgument;
    let a = r.args();
    // The next history written over the one read (in place).
    let past_copy = r.past.clone();
    let mut b = a;
    b.next.data = r.hist.texels.data.cast_mut();
    r.refused(inv, "next` overlaps `history.texels", b);
    assert!(r
        .past
        .iter()
        .zip(&past_copy)
        .all(|(x, y)| bits(x) == bits(y)));
    // The next history over the current colors (refused before its
    // length, which the colors could not hold, is ever used).
    let cur_copy = r.inp.current.clone();
    let mut b = a;
    // SAFETY: in bounds of `current` (12 bytes a texel, N of them).
    b.next.data = unsafe { r.inp.current.as_ptr().cast_mut().cast::<u8>().add(12) }.cast();
    r.refused(inv, "next` overlaps `current", b);
    assert_eq!(r.inp.current.len(), cur_copy.len());
    assert!(r
        .inp
        .current
        .iter()
        .zip(&cur_copy)
        .all(|(x, y)| x.map(f32::to_bits) == y.map(f32::to_bits)));
    // The statuses over the next history, over the answered flags, over a
    // G-buffer image.
    let mut b = a;
    b.status.data = b.next.data.cast();
    r.refused(inv, "next` overlaps `status", b);
    let mut b = a;
    b.status.data = r.inp.answered.as_ptr().cast_mut();
    r.refused(inv, "status` overlaps `answered", b);
    let mut b = a;
    b.status.data = r.g.depth.depth.data.cast_mut().cast();
    r.refused(inv, "status` overlaps `gbuffer.depth", b);
    // The stats inside the next history.
    let b = Args {
        out_stats: r.next.as_mut_ptr().cast(),
        ..a
    };
    r.reset();
    // SAFETY: within `next`; refused before any write.
    let s = unsafe { b.call() };
    assert_eq!(s, inv);
    assert!(last_error().contains("`next` overlaps `out_stats`"));
    assert!(r.next.iter().all(|t| bits(t) == bits(&sentinel_texel())));
}
