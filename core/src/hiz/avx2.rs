//! The Hi-Z walk as a ray stream of eight AVX2 lanes (issue 14 part 2).
//!
//! The same walk as [`super::Walker`], lane by lane, for the batch entry
//! point's common case (constant thickness, `stop_level` 0, no
//! statistics): eight rays walk at once in structure-of-arrays state, and a
//! lane whose ray finishes (hit, end of segment, iteration cap) is refilled
//! at once with the next ray of the batch, so no lane waits for the
//! slowest ray of a fixed packet. Setup (projection and clipping) and the
//! result (hit refinement, the end texel's miss reason) are the scalar
//! walker's own code, called per ray when a lane is refilled or finishes.
//!
//! Every lane does the scalar walker's f32 operations in its order, with
//! the same operands: the packed `add`/`sub`/`mul`/`div` round as the
//! scalar ones (no FMA is enabled, so none is formed), `max_nn(a, b)` is
//! `_mm256_max_ps(b, a)` (`b > a ? b : a`) and `min_nn` likewise, and the
//! saturating `f32 -> u32` conversions become a clamp into `[0, 2^24]` and
//! `cvttps` (the clamp changes no pixel, below). So every result
//! is the scalar walker's, bit for bit: hit or miss, reason, `t`, depths,
//! pixel and [`crate::Work`] counters (tested against it in the hiz tests,
//! and `examples/depth_kernels_bench --compare`).
//!
//! What the scalar walker does per branch, the lanes do with masks: each
//! iteration computes a visit for all lanes (cell, one texel gather, both
//! exits, the slab), then the crossing and the descent, and selects per
//! lane. The prologue is the same visit at level 0 (a lane counts its
//! prologue visits and then starts the hierarchy at `start_level`). The
//! parent records (per level: the cell's edge pixels and the end of its
//! possible-hit interval) are per-lane arrays, read with a gather and
//! written per descending lane (AVX2 has no scatter).
//!
//! Why the clamp changes no pixel: a frontier sync (`Axis::sync`) clamps
//! its rounded position between the frontier pixel `p` and the cell's edge
//! pixel `e`, both below `2^15` here. Moving toward `+v`, a position below
//! 0 or NaN rounds to 0 in the scalar walk (`v as u32` saturates) and after
//! the clamp alike; one at or past `2^24` rounds to at least `2^24 - 1`
//! after the one-pixel rule either way, which the clamp to `e` makes `e`.
//! Moving toward `-v`, a position at or below 0 or NaN gives `ceil - 1 =
//! -1` both ways, and one past `2^24` a pixel past `p`, which `min(f, p)`
//! makes `p` both ways. Between, `cvttps` of the clamped position is the
//! scalar truncation.
//!
//! Not in the stream (the batch call takes the scalar walk for them):
//! back-face thickness, `stop_level > 0` (unit steps through a cell), the
//! statistics walk, images wider or taller than 32,768 pixels (so that
//! every pixel index fits the clamp above and the pyramid has at most 16
//! levels, whose offsets the lanes permute out of two vectors), pyramids
//! of more than `i32::MAX` texels, caps above `i32::MAX` iterations, and
//! batches of fewer than [`MIN_RAYS`] rays. When the batch runs out of rays
//! the remaining lanes finish in the stream with the empty lanes masked.

use super::{
    dir_pixel, finish_lane, per_ray, project_segment, Axis, Exit, HiZ, HiZOptions, Segment, State,
    MAX_LEVELS,
};
use crate::trace::{Miss, Thickness, Trace, Work};
use crate::Ray;
use core::arch::x86_64::{
    __m256, __m256i, _mm256_add_epi32, _mm256_add_ps, _mm256_and_si256, _mm256_andnot_si256,
    _mm256_blendv_epi8, _mm256_blendv_ps, _mm256_castpd_ps, _mm256_castps_pd, _mm256_castps_si256,
    _mm256_castsi256_ps, _mm256_castsi256_si128, _mm256_cmp_ps, _mm256_cmpeq_epi32,
    _mm256_cmpgt_epi32, _mm256_cvtepi32_ps, _mm256_cvttps_epi32, _mm256_div_ps,
    _mm256_extracti128_si256, _mm256_i32gather_epi32, _mm256_i32gather_pd, _mm256_i32gather_ps,
    _mm256_load_ps, _mm256_load_si256, _mm256_loadu_si256, _mm256_max_epi32, _mm256_max_ps,
    _mm256_min_epi32, _mm256_min_ps, _mm256_movemask_ps, _mm256_mul_ps, _mm256_mullo_epi32,
    _mm256_or_si256, _mm256_permute4x64_pd, _mm256_permutevar8x32_epi32, _mm256_set1_epi32,
    _mm256_set1_ps, _mm256_setr_epi32, _mm256_setzero_si256, _mm256_shuffle_ps, _mm256_sllv_epi32,
    _mm256_srli_epi32, _mm256_srlv_epi32, _mm256_store_ps, _mm256_store_si256, _mm256_sub_epi32,
    _mm256_sub_ps, _CMP_LE_OQ, _CMP_LT_OQ, _CMP_NLT_UQ,
};

cpufeatures::new!(cpuid_avx2, "avx2");

/// Lanes of the stream.
const LANES: usize = 8;

/// Smallest batch the stream takes; smaller ones walk scalar (filling
/// eight lanes costs more than it saves there).
pub(super) const MIN_RAYS: usize = 8;

/// Largest image side the stream takes: pixel indices, edge pixels plus
/// one and texel indices stay far inside `i32`, every coordinate the
/// frontier can reach is below `2^24`, where `f32` holds integers exactly,
/// and the pyramid has at most 16 levels (its level offsets fit in two
/// vectors).
const MAX_SIDE: u32 = 1 << 15;

/// Whether this CPU runs the AVX2 stream (CPUID and the OS's saved
/// register state, checked once and cached).
pub(super) fn available() -> bool {
    cpuid_avx2::get()
}

/// Whether the stream walks this batch as the scalar walker would: the
/// batch entry point's constant-thickness case with `stop_level` 0, within
/// the stream's size limits (see the module docs).
pub(super) fn takes(hiz: &HiZ<'_>, options: &HiZOptions, rays: usize) -> bool {
    let l = &hiz.layout;
    let top = l.count - 1;
    rays >= MIN_RAYS
        && options.stop_level.min(top) == 0
        && options.max_iterations <= i32::MAX as u32
        && l.width <= MAX_SIDE
        && l.height <= MAX_SIDE
        && hiz.data.len() <= i32::MAX as usize
        && l.len <= hiz.data.len()
        // The level sizes the lanes compute, `max(1, side >> L)`, are the
        // layout's (they are by construction; checked, as the gathers
        // rely on them).
        && l.levels[..l.count as usize].iter().enumerate().all(|(i, v)| {
            v.width == (l.width >> i).max(1)
                && v.height == (l.height >> i).max(1)
                && v.offset + (v.width as usize) * (v.height as usize) <= l.len
        })
}

/// Per-lane values, one array of eight per field, aligned for vector
/// loads.
#[repr(C, align(32))]
#[derive(Clone, Copy)]
struct Lanes {
    // The segment's axes: `v0`, `d` (for positions) and the exit's
    // `exit_v0`, `exit_d` (`-inf`, `+0` when the axis does not move), as
    // `Axis`.
    x0: [f32; LANES],
    dx: [f32; LANES],
    ex_x0: [f32; LANES],
    ex_dx: [f32; LANES],
    y0: [f32; LANES],
    dy: [f32; LANES],
    ex_y0: [f32; LANES],
    ex_dy: [f32; LANES],
    q0: [f32; LANES],
    dq: [f32; LANES],
    /// The ray's constant thickness.
    th: [f32; LANES],
    /// All ones where the class moves toward `-x`, `-y`, smaller `q`.
    negx: [i32; LANES],
    negy: [i32; LANES],
    negq: [i32; LANES],
    // What the walk changes.
    s: [f32; LANES],
    px: [i32; LANES],
    py: [i32; LANES],
    level: [i32; LANES],
    /// Hierarchical iterations left before the cap.
    left: [i32; LANES],
    /// Prologue visits done.
    pro: [i32; LANES],
    steps: [i32; LANES],
    /// Bit `L` set where the lane's parent record of level `L` is from
    /// this ray (a new ray has none: `-inf`, as the scalar walk's reset).
    pset: [i32; LANES],
    /// All ones where the lane walks a ray.
    active: [i32; LANES],
}

/// Per-lane parent records, `[level * LANES + lane]` (see the scalar walk's
/// `parent_ex`, `parent_ey`, `parent_sb`), the edge pixels packed as
/// `ex | ey << 16`.
#[repr(C, align(32))]
struct Parents {
    exy: [i32; MAX_LEVELS * LANES],
    sb: [f32; MAX_LEVELS * LANES],
}

/// One iteration's per-lane outcome, for the lanes that finish.
#[repr(C, align(32))]
struct Out {
    a: [f32; LANES],
    zmin: [f32; LANES],
    ex: [i32; LANES],
    ey: [i32; LANES],
    sb: [f32; LANES],
    level: [i32; LANES],
}

/// Traces every ray as `super::trace_valid::<false>` would, into `out`.
/// The rays, `t_max` and the constant thicknesses `th` are already
/// validated (`th` and `t_max`: one value for every ray, or one per ray),
/// and [`takes`] holds.
///
/// # Safety
/// The CPU supports AVX2 ([`available`]).
#[target_feature(enable = "avx2")]
pub(super) unsafe fn trace_rays<O: From<Trace>, R: Copy + Into<Ray>>(
    out: &mut [O],
    hiz: &HiZ<'_>,
    th: &[f32],
    rays: &[R],
    t_max: &[f32],
    options: &HiZOptions,
) {
    let layout = &hiz.layout;
    let (w, h) = (layout.width, layout.height);
    let top = layout.count - 1;
    let start = options.start_level.min(top) as i32;
    let pro_steps = options.prologue_steps.min(i32::MAX as u32) as i32;
    let max_iter = options.max_iterations as i32;
    let mut offsets = [0i32; MAX_LEVELS];
    for (o, c) in offsets.iter_mut().zip(&hiz.cells[..layout.count as usize]) {
        *o = c.offset as i32;
    }
    let data = hiz.data;
    let far = hiz.camera.far();

    let mut ln = Lanes {
        x0: [0.0; LANES],
        dx: [1.0; LANES],
        ex_x0: [0.0; LANES],
        ex_dx: [1.0; LANES],
        y0: [0.0; LANES],
        dy: [1.0; LANES],
        ex_y0: [0.0; LANES],
        ex_dy: [1.0; LANES],
        q0: [1.0; LANES],
        dq: [1.0; LANES],
        th: [0.0; LANES],
        negx: [0; LANES],
        negy: [0; LANES],
        negq: [0; LANES],
        s: [0.0; LANES],
        px: [0; LANES],
        py: [0; LANES],
        level: [0; LANES],
        left: [0; LANES],
        pro: [0; LANES],
        steps: [0; LANES],
        pset: [0; LANES],
        active: [0; LANES],
    };
    let mut par = Parents {
        exy: [0; MAX_LEVELS * LANES],
        sb: [f32::NEG_INFINITY; MAX_LEVELS * LANES],
    };
    let mut res = Out {
        a: [0.0; LANES],
        zmin: [0.0; LANES],
        ex: [0; LANES],
        ey: [0; LANES],
        sb: [0.0; LANES],
        level: [0; LANES],
    };
    let mut feed = Feed {
        hiz,
        rays,
        t_max,
        th,
        next: 0,
        segs: [None; LANES],
        ray_of: [0; LANES],
        level0: if pro_steps > 0 { 0 } else { start },
        max_iter,
    };
    let mut busy = 0;
    for k in 0..LANES {
        busy += usize::from(feed.refill(&mut ln, k, out));
    }

    let zero = _mm256_setzero_si256();
    let ones = _mm256_set1_epi32(-1);
    let one_i = _mm256_set1_epi32(1);
    let one_f = _mm256_set1_ps(1.0);
    let zero_f = _mm256_set1_ps(0.0);
    let big_f = _mm256_set1_ps(16_777_216.0);
    let wv = _mm256_set1_epi32(w as i32);
    let hv = _mm256_set1_epi32(h as i32);
    let w1 = _mm256_set1_epi32(w as i32 - 1);
    let h1 = _mm256_set1_epi32(h as i32 - 1);
    let farv = _mm256_set1_ps(far);
    let prov = _mm256_set1_epi32(pro_steps);
    let startv = _mm256_set1_epi32(start);
    let topv = _mm256_set1_epi32(top as i32);
    let lenv = _mm256_set1_epi32(data.len() as i32);
    let lane_id = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    let lanes_v = _mm256_set1_epi32(LANES as i32);
    let seven = _mm256_set1_epi32(7);
    let off_lo = _mm256_loadu_si256(offsets.as_ptr().cast());
    let off_hi = _mm256_loadu_si256(offsets[8..].as_ptr().cast());

    while busy > 0 {
        macro_rules! ld {
            (f $f:ident) => {
                _mm256_load_ps(ln.$f.as_ptr())
            };
            (i $f:ident) => {
                _mm256_load_si256(ln.$f.as_ptr().cast())
            };
        }
        macro_rules! st {
            (f $f:ident, $v:expr) => {
                _mm256_store_ps(ln.$f.as_mut_ptr(), $v)
            };
            (i $f:ident, $v:expr) => {
                _mm256_store_si256(ln.$f.as_mut_ptr().cast(), $v)
            };
        }
        // Vector helpers as macros, not closures or functions: everything
        // stays in this `#[target_feature]` body (see the module docs).
        // `m ? b : a`, lane by lane, for all-ones / all-zeros masks.
        macro_rules! seli {
            ($m:expr, $b:expr, $a:expr $(,)?) => {
                _mm256_blendv_epi8($a, $b, $m)
            };
        }
        macro_rules! self_ {
            ($m:expr, $b:expr, $a:expr $(,)?) => {
                _mm256_blendv_ps($a, $b, _mm256_castsi256_ps($m))
            };
        }
        macro_rules! fm {
            ($m:expr) => {
                _mm256_castps_si256($m)
            };
        }

        let s = ld!(f s);
        let px = ld!(i px);
        let py = ld!(i py);
        let level = ld!(i level);
        let left = ld!(i left);
        let pro = ld!(i pro);
        let act = ld!(i active);
        let negx = ld!(i negx);
        let negy = ld!(i negy);
        let negq = ld!(i negq);

        // Prologue lanes (`pro < prologue_steps`) visit level 0 and do not
        // count iterations; the others stop at the cap before visiting.
        let inpro = _mm256_cmpgt_epi32(prov, pro);
        let oos = _mm256_andnot_si256(inpro, _mm256_and_si256(act, _mm256_cmpeq_epi32(left, zero)));
        let vis = _mm256_andnot_si256(oos, act);
        let left = _mm256_add_epi32(left, _mm256_andnot_si256(inpro, vis));
        let pro = _mm256_sub_epi32(pro, _mm256_and_si256(inpro, vis));

        // The cell of `level` holding the frontier (`Walker::cell`).
        let wl = _mm256_max_epi32(_mm256_srlv_epi32(wv, level), one_i);
        let hl = _mm256_max_epi32(_mm256_srlv_epi32(hv, level), one_i);
        let last_x = _mm256_sub_epi32(wl, one_i);
        let last_y = _mm256_sub_epi32(hl, one_i);
        let cx = _mm256_min_epi32(_mm256_srlv_epi32(px, level), last_x);
        let cy = _mm256_min_epi32(_mm256_srlv_epi32(py, level), last_y);
        // Edge pixels (`Axis::edge`).
        macro_rules! edge {
            ($c:expr, $last:expr, $size1:expr, $neg:expr) => {{
                let c: __m256i = $c;
                let lo = _mm256_sllv_epi32(c, level);
                let hi =
                    _mm256_sub_epi32(_mm256_sllv_epi32(_mm256_add_epi32(c, one_i), level), one_i);
                // `c >= last`: not `last > c`.
                let at_last = _mm256_andnot_si256(_mm256_cmpgt_epi32($last, c), ones);
                seli!($neg, lo, seli!(at_last, $size1, hi))
            }};
        }
        let ex = edge!(cx, last_x, w1, negx);
        let ey = edge!(cy, last_y, h1, negy);
        // The level's first texel from the two eight-entry halves of the
        // offset table (levels 0-7 and 8-15), two permutes and a blend
        // rather than a gather.
        let off = seli!(
            _mm256_cmpgt_epi32(level, seven),
            _mm256_permutevar8x32_epi32(off_hi, level),
            _mm256_permutevar8x32_epi32(off_lo, level),
        );
        let idx = _mm256_add_epi32(off, _mm256_add_epi32(_mm256_mullo_epi32(cy, wl), cx));
        // In the pyramid (always, for a bound `HiZ`; a lane outside ends
        // as the scalar visit does), and only for visiting lanes.
        let inb = _mm256_and_si256(
            vis,
            _mm256_and_si256(
                _mm256_cmpgt_epi32(lenv, idx),
                _mm256_cmpgt_epi32(idx, _mm256_set1_epi32(-1)),
            ),
        );
        let idx = _mm256_and_si256(idx, inb);
        // Texels `[zmin, zmax]` as eight-byte elements, then split.
        let t_lo = _mm256_i32gather_pd::<8>(data.as_ptr().cast(), _mm256_castsi256_si128(idx));
        let t_hi =
            _mm256_i32gather_pd::<8>(data.as_ptr().cast(), _mm256_extracti128_si256::<1>(idx));
        let (a4, b4) = (_mm256_castpd_ps(t_lo), _mm256_castpd_ps(t_hi));
        // [a.min0 a.min1 b.min4 b.min5 | a.min2 a.min3 b.min6 b.min7] -> lane order.
        macro_rules! unzip {
            ($v:expr) => {
                _mm256_castpd_ps(_mm256_permute4x64_pd::<0xD8>(_mm256_castps_pd($v)))
            };
        }
        let zmin: __m256 = unzip!(_mm256_shuffle_ps::<0x88>(a4, b4));
        let zmax: __m256 = unzip!(_mm256_shuffle_ps::<0xDD>(a4, b4));

        // Exits (`Axis::exit`): the side past the edge pixel.
        let bx = _mm256_add_epi32(ex, _mm256_andnot_si256(negx, one_i));
        let by = _mm256_add_epi32(ey, _mm256_andnot_si256(negy, one_i));
        let sx = _mm256_div_ps(
            _mm256_sub_ps(_mm256_cvtepi32_ps(bx), ld!(f ex_x0)),
            ld!(f ex_dx),
        );
        let sy = _mm256_div_ps(
            _mm256_sub_ps(_mm256_cvtepi32_ps(by), ld!(f ex_y0)),
            ld!(f ex_dy),
        );
        let es = _mm256_min_ps(sy, sx);
        let to = _mm256_min_ps(one_f, es);

        // The slab (`Walker::slab`, `Walker::upper`).
        let thv = ld!(f th);
        let q0 = ld!(f q0);
        let dq = ld!(f dq);
        let l0 = _mm256_cmpeq_epi32(level, zero);
        let valid = fm!(_mm256_cmp_ps::<_CMP_LT_OQ>(zmin, farv));
        let upper = self_!(
            l0,
            _mm256_add_ps(zmin, thv),
            _mm256_add_ps(_mm256_max_ps(zmax, zmin), thv)
        );
        let za = self_!(negq, zmin, upper);
        let zb = self_!(negq, upper, zmin);
        let ea = _mm256_div_ps(_mm256_sub_ps(_mm256_div_ps(one_f, za), q0), dq);
        let a = _mm256_max_ps(ea, s);
        let eb = _mm256_div_ps(_mm256_sub_ps(_mm256_div_ps(one_f, zb), q0), dq);
        let b = _mm256_min_ps(eb, to);
        let past = fm!(_mm256_cmp_ps::<_CMP_LT_OQ>(to, a));
        let meets = fm!(_mm256_cmp_ps::<_CMP_LE_OQ>(a, b));
        let nonempty = _mm256_and_si256(_mm256_andnot_si256(past, valid), meets);
        let found = _mm256_and_si256(inb, nonempty);
        let hit = _mm256_and_si256(found, l0);
        let inside = _mm256_andnot_si256(l0, found);
        let empty = _mm256_andnot_si256(nonempty, inb);

        // The crossing (`Walker::cross`, `Axis::next`).
        let ends = fm!(_mm256_cmp_ps::<_CMP_NLT_UQ>(es, one_f));
        let x_only = fm!(_mm256_cmp_ps::<_CMP_LT_OQ>(sx, sy));
        let y_only = fm!(_mm256_cmp_ps::<_CMP_LT_OQ>(sy, sx));
        let corner = _mm256_andnot_si256(_mm256_or_si256(x_only, y_only), ones);
        let nx = seli!(
            negx,
            _mm256_sub_epi32(ex, one_i),
            _mm256_add_epi32(ex, one_i)
        );
        let ny = seli!(
            negy,
            _mm256_sub_epi32(ey, one_i),
            _mm256_add_epi32(ey, one_i)
        );
        // Past the image: `ex == 0` toward -x, `ex + 1 >= w` toward +x.
        let nx_out = seli!(
            negx,
            _mm256_cmpeq_epi32(ex, zero),
            _mm256_andnot_si256(_mm256_cmpgt_epi32(wv, nx), ones)
        );
        let ny_out = seli!(
            negy,
            _mm256_cmpeq_epi32(ey, zero),
            _mm256_andnot_si256(_mm256_cmpgt_epi32(hv, ny), ones)
        );
        let blocked = _mm256_or_si256(
            _mm256_or_si256(
                _mm256_and_si256(x_only, nx_out),
                _mm256_and_si256(y_only, ny_out),
            ),
            _mm256_and_si256(corner, _mm256_or_si256(nx_out, ny_out)),
        );
        let cend = _mm256_or_si256(ends, blocked);
        let end = _mm256_or_si256(_mm256_and_si256(empty, cend), _mm256_andnot_si256(inb, vis));
        let crossing = _mm256_andnot_si256(cend, empty);
        let steps = _mm256_sub_epi32(ld!(i steps), crossing);

        // The new `s`: the crossing's (`Walker::advance`), or a descent's
        // slab entry when it lies past `s`.
        let moved = _mm256_and_si256(inside, fm!(_mm256_cmp_ps::<_CMP_LT_OQ>(s, a)));
        let s_new = self_!(crossing, _mm256_max_ps(es, s), self_!(moved, a, s));

        // Frontier syncs at the new `s` (`Axis::sync`), both axes for every
        // lane; each lane keeps the ones its branch does.
        macro_rules! sync {
            ($v0:expr, $d:expr, $p:expr, $e:expr, $neg:expr) => {{
            let (v0, d, p, e, neg): (__m256, __m256, __m256i, __m256i, __m256i) = ($v0, $d, $p, $e, $neg);
            let v = _mm256_add_ps(v0, _mm256_mul_ps(s_new, d));
            // Clamped into [0, 2^24] (NaN to 0) before the truncation: the
            // pixels between `p` and `e` lie far inside, and a clamped
            // position ends in the same pixel (module docs).
            let vc = _mm256_min_ps(_mm256_max_ps(v, zero_f), big_f);
            let c = _mm256_cvttps_epi32(vc);
            // +v: f = floor(v), one back if `s` is still inside pixel
            // f - 1 (exit parameter at boundary f).
            let fp = c;
            // -v: f = ceil(v) - 1, one forward if `s` is still inside
            // pixel f + 1 (exit parameter at boundary f + 1).
            let up = fm!(_mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_cvtepi32_ps(c), vc));
            let fnv = _mm256_sub_epi32(_mm256_sub_epi32(c, up), one_i);
            let f1 = _mm256_add_epi32(fnv, one_i);
            // Where the one-pixel rule can move the pixel: `f > p` toward
            // +v, `f < p` toward -v.
            let may = seli!(neg, _mm256_cmpgt_epi32(p, fnv), _mm256_cmpgt_epi32(fp, p));
            // The rule's exit parameter, one division per lane with the
            // lane's own boundary (the scalar sync divides only in the
            // lane's direction), and only when some lane needs it.
            let inside = if _mm256_movemask_ps(_mm256_castsi256_ps(may)) != 0 {
                let bnd = seli!(neg, f1, fp);
                fm!(_mm256_cmp_ps::<_CMP_LE_OQ>(
                    s_new,
                    _mm256_div_ps(_mm256_sub_ps(_mm256_cvtepi32_ps(bnd), v0), d),
                ))
            } else {
                zero
            };
            let adj = _mm256_and_si256(may, inside);
            let rp = _mm256_min_epi32(_mm256_max_epi32(_mm256_add_epi32(fp, adj), p), e);
            let rn = _mm256_max_epi32(_mm256_min_epi32(_mm256_sub_epi32(fnv, adj), p), e);
            seli!(neg, rn, rp)
            }};
        }
        let sxn = sync!(ld!(f x0), ld!(f dx), px, ex, negx);
        let syn = sync!(ld!(f y0), ld!(f dy), py, ey, negy);
        let cx_only = _mm256_and_si256(crossing, x_only);
        let cy_only = _mm256_and_si256(crossing, y_only);
        let c_corner = _mm256_and_si256(crossing, corner);
        let takes_nx = _mm256_or_si256(cx_only, c_corner);
        let takes_ny = _mm256_or_si256(cy_only, c_corner);
        let takes_sx = _mm256_or_si256(cy_only, moved);
        let takes_sy = _mm256_or_si256(cx_only, moved);
        let px_new = seli!(takes_nx, nx, seli!(takes_sx, sxn, px));
        let py_new = seli!(takes_ny, ny, seli!(takes_sy, syn, py));

        // Levels. A prologue lane that has made its visits starts the
        // hierarchy; a hierarchical crossing goes up unless still inside
        // the parent before its interval's end; a descent goes down.
        let pro_done = _mm256_andnot_si256(
            _mm256_cmpgt_epi32(prov, pro),
            _mm256_and_si256(inpro, crossing),
        );
        let hcross = _mm256_andnot_si256(inpro, crossing);
        let below_top = _mm256_cmpgt_epi32(topv, level);
        let up = _mm256_min_epi32(_mm256_add_epi32(level, one_i), topv);
        let pidx = _mm256_add_epi32(_mm256_mullo_epi32(up, lanes_v), lane_id);
        // Edge pixels packed as `ex | ey << 16` (both below 2^15): one
        // gather for the two.
        let pexy = _mm256_i32gather_epi32::<4>(par.exy.as_ptr(), pidx);
        let pex = _mm256_and_si256(pexy, _mm256_set1_epi32(0xFFFF));
        let pey = _mm256_srli_epi32::<16>(pexy);
        let psb = _mm256_i32gather_ps::<4>(par.sb.as_ptr(), pidx);
        // `holds` (`Walker::holds`): not past the parent's edge pixels.
        let out_x = seli!(
            negx,
            _mm256_cmpgt_epi32(pex, px_new),
            _mm256_cmpgt_epi32(px_new, pex)
        );
        let out_y = seli!(
            negy,
            _mm256_cmpgt_epi32(pey, py_new),
            _mm256_cmpgt_epi32(py_new, pey)
        );
        let holds = _mm256_andnot_si256(_mm256_or_si256(out_x, out_y), ones);
        // A record not set for this ray is `-inf`: `s > sb` holds.
        let pset = ld!(i pset);
        let unset = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_srlv_epi32(pset, up), one_i), zero);
        let after = _mm256_or_si256(unset, fm!(_mm256_cmp_ps::<_CMP_LT_OQ>(psb, s_new)));
        let go_up = _mm256_and_si256(
            _mm256_and_si256(hcross, below_top),
            _mm256_or_si256(_mm256_andnot_si256(holds, ones), after),
        );
        let level_new = seli!(
            pro_done,
            startv,
            seli!(go_up, up, _mm256_add_epi32(level, inside)),
        );

        st!(f s, s_new);
        st!(i px, px_new);
        st!(i py, py_new);
        st!(i level, level_new);
        st!(i left, left);
        st!(i pro, pro);
        st!(i steps, steps);

        // Descents record their cell as the parent of the level below.
        let down = _mm256_movemask_ps(_mm256_castsi256_ps(inside)) as u32;
        let exits = _mm256_or_si256(_mm256_or_si256(hit, end), oos);
        let done = _mm256_movemask_ps(_mm256_castsi256_ps(exits)) as u32;
        if down | done != 0 {
            _mm256_store_ps(res.a.as_mut_ptr(), a);
            _mm256_store_ps(res.zmin.as_mut_ptr(), zmin);
            _mm256_store_si256(res.ex.as_mut_ptr().cast(), ex);
            _mm256_store_si256(res.ey.as_mut_ptr().cast(), ey);
            _mm256_store_ps(res.sb.as_mut_ptr(), b);
            _mm256_store_si256(res.level.as_mut_ptr().cast(), level);
        }
        let mut m = down;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            let j = res.level[k] as usize % MAX_LEVELS * LANES + k;
            par.exy[j] = res.ex[k] | res.ey[k] << 16;
            par.sb[j] = res.sb[k];
            ln.pset[k] |= 1 << (res.level[k] as u32 % MAX_LEVELS as u32);
        }
        if done != 0 {
            let hits = _mm256_movemask_ps(_mm256_castsi256_ps(hit)) as u32;
            let oos_m = _mm256_movemask_ps(_mm256_castsi256_ps(oos)) as u32;
            let mut m = done;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                let Some(seg) = feed.segs[k] else {
                    continue;
                };
                let st = State {
                    s: ln.s[k],
                    px: ln.px[k] as u32,
                    py: ln.py[k] as u32,
                    steps: ln.steps[k] as u64,
                    fetches: ln.pro[k] as u64,
                    iterations: (max_iter - ln.left[k]) as u32,
                    stats: Default::default(),
                };
                let exit = if hits & (1 << k) != 0 {
                    Exit::Hit {
                        s: res.a[k],
                        surface: res.zmin[k],
                    }
                } else if oos_m & (1 << k) != 0 {
                    Exit::OutOfSteps
                } else {
                    Exit::End
                };
                out[feed.ray_of[k]] =
                    finish_lane(hiz, Thickness::Constant(ln.th[k]), seg, st, exit).into();
                if !feed.refill(&mut ln, k, out) {
                    busy -= 1;
                }
            }
        }
    }
}

/// The batch's rays as the lanes take them, and what each lane walks.
struct Feed<'h, 'a, 'r, R> {
    hiz: &'h HiZ<'a>,
    rays: &'r [R],
    t_max: &'r [f32],
    th: &'r [f32],
    /// The next ray to take.
    next: usize,
    /// Each lane's segment (`None`: the lane is empty) and ray index.
    segs: [Option<Segment>; LANES],
    ray_of: [usize; LANES],
    /// The level a new ray starts at: 0 for the prologue, else the start
    /// level.
    level0: i32,
    max_iter: i32,
}

impl<R: Copy + Into<Ray>> Feed<'_, '_, '_, R> {
    /// Fills lane `k` with the next ray that projects to a segment (the
    /// others get their miss at once); returns whether one was left, and
    /// empties the lane if not.
    fn refill<O: From<Trace>>(&mut self, ln: &mut Lanes, k: usize, out: &mut [O]) -> bool {
        let (w, h) = (self.hiz.layout.width, self.hiz.layout.height);
        while self.next < self.rays.len() {
            let i = self.next;
            self.next += 1;
            let ray: Ray = self.rays[i].into();
            let Some(seg) = project_segment(self.hiz, &ray, per_ray(self.t_max, i)) else {
                out[i] = Trace::Miss {
                    reason: Miss::DegenerateProjection,
                    work: Work::default(),
                }
                .into();
                continue;
            };
            let ax = Axis::<false>::new(seg.x0, seg.dx, w);
            let ay = Axis::<false>::new(seg.y0, seg.dy, h);
            ln.x0[k] = seg.x0;
            ln.dx[k] = seg.dx;
            ln.ex_x0[k] = ax.exit_v0;
            ln.ex_dx[k] = ax.exit_d;
            ln.y0[k] = seg.y0;
            ln.dy[k] = seg.dy;
            ln.ex_y0[k] = ay.exit_v0;
            ln.ex_dy[k] = ay.exit_d;
            ln.q0[k] = seg.q0;
            ln.th[k] = per_ray(self.th, i);
            ln.dq[k] = seg.dq;
            ln.negx[k] = -i32::from(seg.dx < 0.0);
            ln.negy[k] = -i32::from(seg.dy < 0.0);
            ln.negq[k] = -i32::from(seg.dq < 0.0);
            ln.s[k] = 0.0;
            ln.px[k] = dir_pixel(seg.x0, seg.dx, w) as i32;
            ln.py[k] = dir_pixel(seg.y0, seg.dy, h) as i32;
            ln.level[k] = self.level0;
            ln.left[k] = self.max_iter;
            ln.pro[k] = 0;
            ln.steps[k] = 0;
            ln.pset[k] = 0;
            ln.active[k] = -1;
            self.segs[k] = Some(seg);
            self.ray_of[k] = i;
            return true;
        }
        ln.active[k] = 0;
        self.segs[k] = None;
        false
    }
}
