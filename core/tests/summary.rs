//! The frame summary (`refl_core::summary`) against a brute-force count of
//! the analytic scene (a floor, a sphere and a box; depth and normals
//! rendered in f64), with a mask and a roughness image: counts per object
//! and class, border pixels, rectangles, tile classes; the plane test on
//! the floor (planar), the sphere and the box (not), also far from the
//! origin and in every depth convention; bands and merges equal one call;
//! refusals write nothing.
#![cfg(all(feature = "depth-image", feature = "hiz"))]

#[path = "common/scene.rs"]
mod scene;

use refl_core::glam::{DVec3, Vec3};
use refl_core::summary::{
    try_summarize_rows, FrameSummary, ObjectSummary, RoughnessClass, SummaryOptions, NO_OBJECT,
    TILE,
};
use refl_core::{
    Camera, DepthConvention, DepthImage, Error, GBuffer, ImageView, NormalSpace, RowRange,
};
use scene::{default_camera, grazing_camera, render, Frame, CONVENTIONS};

/// A mask and a roughness image for a `w x h` frame: every seventh pixel
/// masked out, roughness cycling through mirror, glossy, rough and NaN.
fn extras(w: u32, h: u32) -> (Vec<u8>, Vec<f32>) {
    let n = (w * h) as usize;
    let mask = (0..n).map(|i| u8::from(i % 7 != 3)).collect();
    let rough = (0..n)
        .map(|i| match (i / 3) % 5 {
            0 | 1 => 0.05,
            2 => 0.4,
            3 => 1.5,
            _ => f32::NAN,
        })
        .collect();
    (mask, rough)
}

fn gbuffer<'a>(f: &'a Frame, mask: &'a [u8], rough: &'a [f32]) -> GBuffer<'a> {
    let (w, h) = (f.camera.width(), f.camera.height());
    f.gbuffer(false)
        .try_with_mask(ImageView::try_new(mask, w, h, w).unwrap())
        .unwrap()
        .try_with_roughness(ImageView::try_new(rough, w, h, w).unwrap())
        .unwrap()
}

fn options() -> SummaryOptions {
    SummaryOptions {
        glossy_roughness: 1.0,
        ..SummaryOptions::default()
    }
}

/// The brute-force counts: per object (3) pixels, classes, border pixels,
/// rectangle; the frame's counts and tiles.
struct Oracle {
    pixels: [u64; 3],
    classes: [[u64; 3]; 3],
    border: [u64; 3],
    rect: [[u32; 4]; 3],
    frame: FrameSummary,
}

fn oracle(f: &Frame, mask: &[u8], rough: &[f32], o: &SummaryOptions) -> Oracle {
    let (w, h) = (f.camera.width(), f.camera.height());
    let mut r = Oracle {
        pixels: [0; 3],
        classes: [[0; 3]; 3],
        border: [0; 3],
        rect: [[0; 4]; 3],
        frame: FrameSummary::default(),
    };
    let b = o.border_pixels;
    let mut tile_best = vec![3usize; (w.div_ceil(TILE) * h.div_ceil(TILE)) as usize];
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            r.frame.pixels += 1;
            // The render leaves sky pixels with id u32::MAX (far depth).
            let id = f.id[i];
            if id == u32::MAX {
                continue;
            }
            r.frame.surfaces += 1;
            if mask[i] == 0 || rough[i].is_nan() {
                continue;
            }
            let class = if rough[i] <= o.mirror_roughness {
                0
            } else if rough[i] <= o.glossy_roughness {
                1
            } else {
                2
            };
            let border = x < b || y < b || x + b >= w || y + b >= h;
            let k = id as usize;
            r.pixels[k] += 1;
            r.classes[k][class] += 1;
            r.border[k] += u64::from(border);
            if r.pixels[k] == 1 {
                r.rect[k] = [x, y, x + 1, y + 1];
            }
            r.rect[k] = [
                r.rect[k][0].min(x),
                r.rect[k][1].min(y),
                r.rect[k][2].max(x + 1),
                r.rect[k][3].max(y + 1),
            ];
            r.frame.reflective += 1;
            r.frame.classes[class] += 1;
            r.frame.border += u64::from(border);
            let t = ((y / TILE) * w.div_ceil(TILE) + x / TILE) as usize;
            tile_best[t] = tile_best[t].min(class);
        }
    }
    for t in tile_best {
        r.frame.tiles[(t + 1) % 4] += 1;
    }
    r
}

fn summarize(
    g: &GBuffer<'_>,
    ids: &[u32],
    rows: RowRange,
    o: &SummaryOptions,
) -> (FrameSummary, [ObjectSummary; 3]) {
    let (w, h) = (g.width(), g.height());
    let (mut frame, mut objects) = (FrameSummary::default(), [ObjectSummary::default(); 3]);
    let v = ImageView::try_new(ids, w, h, w).unwrap();
    try_summarize_rows(&mut frame, &mut objects, g, Some(&v), rows, o).unwrap();
    (frame, objects)
}

#[test]
fn counts_equal_a_brute_force_count_in_every_convention() {
    for cam in [default_camera(), grazing_camera()] {
        for conv in CONVENTIONS {
            let f = render(cam, conv);
            let (w, h) = (cam.width(), cam.height());
            let (mask, rough) = extras(w, h);
            let g = gbuffer(&f, &mask, &rough);
            let o = options();
            let want = oracle(&f, &mask, &rough, &o);
            let (frame, objects) = summarize(&g, &f.id, RowRange::try_all(h).unwrap(), &o);
            assert_eq!(frame, want.frame, "{conv:?}");
            for (k, s) in objects.iter().enumerate() {
                assert_eq!(s.pixels, want.pixels[k], "object {k} {conv:?}");
                assert_eq!(s.classes, want.classes[k], "object {k} {conv:?}");
                assert_eq!(s.border_pixels, want.border[k], "object {k} {conv:?}");
                assert_eq!(s.rect, want.rect[k], "object {k} {conv:?}");
            }
            assert!(want.pixels.iter().all(|&p| p > 50), "{:?}", want.pixels);
            assert!(frame.tiles[1] > 0 && frame.tiles[0] > 0);
        }
    }
}

#[test]
fn the_floor_is_planar_the_sphere_and_the_box_are_not() {
    for conv in CONVENTIONS {
        let f = render(default_camera(), conv);
        let (w, h) = (f.camera.width(), f.camera.height());
        let (mask, rough) = extras(w, h);
        let g = gbuffer(&f, &mask, &rough);
        let o = options();
        let (_, objects) = summarize(&g, &f.id, RowRange::try_all(h).unwrap(), &o);
        let floor = objects[0].plane().unwrap();
        assert!((floor.normal - DVec3::Y).length() < 1e-6, "{floor:?}");
        assert!(floor.point.y.abs() < 1e-4, "{floor:?}");
        assert!(floor.coherence > 1.0 - 1e-9, "{floor:?}");
        assert!(floor.rms_distance < 1e-4, "{conv:?}: {floor:?}");
        assert!(objects[0].is_planar(&o), "{conv:?}");
        assert!(!objects[1].is_planar(&o), "sphere {:?}", objects[1].plane());
        assert!(!objects[2].is_planar(&o), "box {:?}", objects[2].plane());
        // One face of the box alone is a plane: the ids of the pixels whose
        // normal is the box's +z face's.
        let ids: Vec<u32> =
            f.id.iter()
                .zip(&f.normals)
                .map(|(&id, n)| if id == 2 && n[2] > 0.5 { 0 } else { NO_OBJECT })
                .collect();
        let (_, face) = summarize(&g, &ids, RowRange::try_all(h).unwrap(), &o);
        assert!(
            face[0].pixels > 20 && face[0].is_planar(&o),
            "{:?}",
            face[0].plane()
        );
    }
}

#[test]
fn bands_and_merges_equal_one_call() {
    let f = render(grazing_camera(), DepthConvention::ReversedZ);
    let (w, h) = (f.camera.width(), f.camera.height());
    let (mask, rough) = extras(w, h);
    let g = gbuffer(&f, &mask, &rough);
    let o = options();
    let (frame, objects) = summarize(&g, &f.id, RowRange::try_all(h).unwrap(), &o);
    // Bands of 16 rows (the last shorter) into one summary, and into
    // separate summaries merged.
    let v = ImageView::try_new(&f.id, w, h, w).unwrap();
    let (mut f1, mut o1) = (FrameSummary::default(), [ObjectSummary::default(); 3]);
    let (mut f2, mut o2) = (FrameSummary::default(), [ObjectSummary::default(); 3]);
    let mut y = 0;
    while y < h {
        let rows = RowRange::try_new(y, (y + 16).min(h), h).unwrap();
        try_summarize_rows(&mut f1, &mut o1, &g, Some(&v), rows, &o).unwrap();
        let (mut fb, mut ob) = (FrameSummary::default(), [ObjectSummary::default(); 3]);
        try_summarize_rows(&mut fb, &mut ob, &g, Some(&v), rows, &o).unwrap();
        f2.merge(&fb);
        for k in 0..3 {
            o2[k].merge(&ob[k]);
        }
        y += 16;
    }
    assert_eq!(f1, frame);
    assert_eq!(f2, frame);
    for k in 0..3 {
        assert_eq!(o1[k], objects[k], "object {k}");
        let (a, b) = (objects[k], o2[k]);
        assert_eq!(
            (a.pixels, a.classes, a.border_pixels, a.rect),
            (b.pixels, b.classes, b.border_pixels, b.rect)
        );
        let (pa, pb) = (a.plane().unwrap(), b.plane().unwrap());
        assert!((pa.normal - pb.normal).length() < 1e-12, "{pa:?} {pb:?}");
        assert!((pa.point - pb.point).length() < 1e-9, "{pa:?} {pb:?}");
        assert!(
            (pa.rms_distance - pb.rms_distance).abs() < 1e-9,
            "{pa:?} {pb:?}"
        );
        assert_eq!(a.is_planar(&o), b.is_planar(&o));
    }
}

/// A floor seen from straight above at `offset`: the plane test in f64
/// relative to the first point holds far from the origin (huge scales) as
/// near it.
#[test]
fn a_floor_far_from_the_origin_is_still_a_plane() {
    for offset in [0.0f32, 1e3, 1e5] {
        // 21 rows: the last tile row is partial.
        let (w, h) = (32u32, 21u32);
        let eye = Vec3::new(offset, 3.0, -offset);
        let cam =
            Camera::try_look_at(eye, eye - Vec3::Y * 3.0, Vec3::Z, 1.0, 0.1, 100.0, w, h).unwrap();
        let n = (w * h) as usize;
        // The floor y = 0 at linear depth 3 everywhere (camera straight down).
        let depth = vec![3.0f32; n];
        let normals = vec![[0.0f32, 1.0, 0.0]; n];
        let d = DepthImage::try_new(
            ImageView::try_new(&depth, w, h, w).unwrap(),
            cam,
            DepthConvention::Linear,
        )
        .unwrap();
        let g = GBuffer::try_new(
            d,
            ImageView::try_new(&normals, w, h, w).unwrap(),
            NormalSpace::World,
        )
        .unwrap();
        let (mut frame, mut objects) = (FrameSummary::default(), [ObjectSummary::default()]);
        let o = SummaryOptions::default();
        try_summarize_rows(
            &mut frame,
            &mut objects,
            &g,
            None,
            RowRange::try_all(h).unwrap(),
            &o,
        )
        .unwrap();
        assert_eq!(frame.reflective, n as u64);
        assert_eq!(frame.classes[RoughnessClass::Mirror as usize], n as u64);
        assert_eq!(frame.tiles, [0, 4 * 3, 0, 0]);
        let p = objects[0].plane().unwrap();
        assert!(objects[0].is_planar(&o), "offset {offset}: {p:?}");
        assert!(
            (p.point.x - f64::from(offset)).abs() < 1.0 && p.point.y.abs() < 0.05,
            "{p:?}"
        );
        // Every pixel is within the border band or not, as counted.
        let b = o.border_pixels;
        let inner = u64::from((w - 2 * b) * (h - 2 * b));
        assert_eq!(objects[0].border_pixels, n as u64 - inner);
    }
}

#[test]
fn refusals_write_nothing() {
    let f = render(default_camera(), DepthConvention::Linear);
    let (w, h) = (f.camera.width(), f.camera.height());
    let (mask, rough) = extras(w, h);
    let g = gbuffer(&f, &mask, &rough);
    let v = ImageView::try_new(&f.id, w, h, w).unwrap();
    let short_ids = ImageView::try_new(&f.id, w - 1, h, w).unwrap();
    let o = options();
    let sentinel_f = FrameSummary {
        pixels: 7,
        ..FrameSummary::default()
    };
    let sentinel_o = ObjectSummary {
        pixels: 9,
        ..ObjectSummary::default()
    };
    let all = RowRange::try_all(h).unwrap();
    let bad_options = [
        SummaryOptions {
            mirror_roughness: f32::NAN,
            ..o
        },
        SummaryOptions {
            mirror_roughness: -1.0,
            ..o
        },
        SummaryOptions {
            glossy_roughness: 0.05,
            ..o
        },
        SummaryOptions {
            plane_tolerance: f32::INFINITY,
            ..o
        },
        SummaryOptions {
            normal_cos: 1.5,
            ..o
        },
    ];
    #[allow(clippy::type_complexity)]
    let cases: Vec<(
        Option<&ImageView<'_, u32>>,
        RowRange,
        SummaryOptions,
        usize,
        Error,
    )> = vec![
        (Some(&short_ids), all, o, 3, Error::InvalidArgument),
        (
            Some(&v),
            RowRange::try_new(4, 16, h).unwrap(),
            o,
            3,
            Error::InvalidArgument,
        ),
        (
            Some(&v),
            RowRange::try_new(0, 12, h).unwrap(),
            o,
            3,
            Error::InvalidArgument,
        ),
        (Some(&v), all, o, 0, Error::InsufficientSize),
    ];
    let run = |ids: Option<&ImageView<'_, u32>>, rows: RowRange, opt: &SummaryOptions, k: usize| {
        let (mut fr, mut ob) = (sentinel_f, [sentinel_o; 3]);
        let r = try_summarize_rows(&mut fr, &mut ob[..k], &g, ids, rows, opt);
        assert_eq!(fr, sentinel_f);
        assert!(ob.iter().all(|x| *x == sentinel_o));
        r
    };
    for (ids, rows, opt, k, want) in cases {
        assert_eq!(run(ids, rows, &opt, k), Err(want));
    }
    for opt in bad_options {
        assert_eq!(
            run(Some(&v), all, &opt, 3),
            Err(Error::InvalidArgument),
            "{opt:?}"
        );
    }
    // Ids past the object list are counted, in no object.
    let (mut fr, mut ob) = (FrameSummary::default(), [ObjectSummary::default(); 2]);
    try_summarize_rows(&mut fr, &mut ob, &g, Some(&v), all, &o).unwrap();
    let want = oracle(&f, &mask, &rough, &o);
    assert_eq!(fr.unlisted, want.pixels[2]);
    assert_eq!(ob[1].pixels, want.pixels[1]);
}
