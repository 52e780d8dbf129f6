//! The calibration table (`refl_app::calibration`): the checked-in table
//! reads back with its provenance; malformed tables are refused with a
//! message naming what is wrong, never a panic.

use proptest::prelude::*;
use refl_app::calibration::{Calibration, Technique, BUILTIN};
use refl_core::plan::{CostEntry, Surface};
use refl_core::summary::RoughnessClass;

const HEADER: &str = "method,setting,class,surface,time_ratio,error_255,pixels,frames";

fn table(rows: &str) -> String {
    format!("# command: cargo run --release -- calibrate\n# commit: abc123\n# date: x\n{HEADER}\n{rows}")
}

#[test]
fn builtin_table_reads_with_provenance_and_every_kind() {
    let cal = Calibration::builtin().unwrap();
    assert!(
        cal.command.starts_with("cargo run --release -- calibrate"),
        "{}",
        cal.command
    );
    assert!(!cal.commit.is_empty() && cal.commit != "none");
    // Every kind of pixel the built-in scenes hold has ray tracing and the
    // environment; planar mirrors have the planar pass.
    let has = |t: Technique, c: RoughnessClass, s: Surface| {
        cal.entries
            .iter()
            .any(|e| (e.technique, e.class, e.surface) == (t, c, s))
    };
    for (c, s) in [
        (RoughnessClass::Mirror, Surface::Planar),
        (RoughnessClass::Mirror, Surface::Curved),
        (RoughnessClass::Glossy, Surface::Any),
    ] {
        assert!(has(Technique::EnvMap, c, s), "{c:?} {s:?}");
        assert!(has(Technique::Ray { samples: 1 }, c, s), "{c:?} {s:?}");
    }
    assert!(has(
        Technique::Planar { scale: 1 },
        RoughnessClass::Mirror,
        Surface::Planar
    ));
    // refl-core accepts it.
    let t = cal.cost_table();
    assert_eq!(t.len(), cal.entries.len());
    assert!(t.iter().all(|e: &CostEntry| e.try_validate().is_ok()));
    // Round trip.
    assert_eq!(Calibration::parse(&cal.to_csv()).unwrap(), cal);
    assert_eq!(Calibration::parse(BUILTIN).unwrap(), cal);
}

#[test]
fn a_small_table_reads_as_written() {
    let cal = Calibration::parse(&table(
        "ray,spp=4,glossy,any,5.5,2.5,100,2\nplanar,resolution=1/2,mirror,planar,0.7,1.1,50,1\n",
    ))
    .unwrap();
    assert_eq!(cal.commit, "abc123");
    assert_eq!(cal.notes, ["date: x"]);
    assert_eq!(cal.entries[0].technique, Technique::Ray { samples: 4 });
    assert_eq!(cal.entries[1].technique, Technique::Planar { scale: 2 });
    assert_eq!(cal.entries[1].surface, Surface::Planar);
    assert_eq!(
        (cal.entries[1].time_ratio, cal.entries[1].error_255),
        (0.7, 1.1)
    );
    assert_eq!((cal.entries[0].pixels, cal.entries[0].frames), (100, 2));
}

#[test]
fn malformed_tables_are_refused_with_the_reason() {
    let ok = "ray,spp=1,mirror,any,1.0,0.0,10,1\n";
    let cases: Vec<(String, &str)> = vec![
        (format!("# commit: a\n{HEADER}\n{ok}"), "command"),
        (format!("# command: x\n{HEADER}\n{ok}"), "commit"),
        (
            format!("# command: x\n# commit: a\nmethod,setting\n{ok}"),
            "header",
        ),
        (table(""), "no rows"),
        (table("ray,spp=1,mirror,any,1.0\n"), "fields"),
        (
            table("ssr,spp=1,mirror,any,1.0,0.0,10,1\n"),
            "unknown method 'ssr'",
        ),
        (table("ray,spp=0,mirror,any,1.0,0.0,10,1\n"), "spp=N"),
        (table("ray,spp=x,mirror,any,1.0,0.0,10,1\n"), "spp=N"),
        (
            table("planar,resolution=2,mirror,planar,1.0,0.0,10,1\n"),
            "resolution=1/N",
        ),
        (table("envmap,mirror,mirror,any,1.0,0.0,10,1\n"), "analytic"),
        (table("ray,spp=1,shiny,any,1.0,0.0,10,1\n"), "class 'shiny'"),
        (
            table("ray,spp=1,mirror,flat,1.0,0.0,10,1\n"),
            "surface 'flat'",
        ),
        (
            table("ray,spp=1,mirror,any,NaN,0.0,10,1\n"),
            "time_ratio 'NaN'",
        ),
        (
            table("ray,spp=1,mirror,any,inf,0.0,10,1\n"),
            "time_ratio 'inf'",
        ),
        (
            table("ray,spp=1,mirror,any,1.0,-1,10,1\n"),
            "error_255 '-1'",
        ),
        (
            table("ray,spp=1,mirror,any,1.0,1e40,10,1\n"),
            "error_255 '1e40'",
        ),
        (
            table("ray,spp=1,mirror,any,1.0,0.0,1.5,1\n"),
            "pixels '1.5'",
        ),
        (
            table("ray,spp=1,mirror,any,1.0,0.0,10,99999999999\n"),
            "line 5: frames '99999999999' is too large",
        ),
        (table(&format!("{ok}{ok}")), "measured twice"),
    ];
    for (text, want) in cases {
        let e = Calibration::parse(&text).unwrap_err();
        assert!(e.contains(want), "'{want}' not in '{e}' for\n{text}");
    }
}

proptest! {
    /// Any text, and any one-byte change of the checked-in table, reads or
    /// is refused: never a panic.
    #[test]
    fn parse_never_panics(text in ".{0,300}", at in 0usize..4000, byte in any::<u8>()) {
        let _ = Calibration::parse(&text);
        let mut b = BUILTIN.as_bytes().to_vec();
        let at = at % b.len();
        b[at] = byte;
        let _ = Calibration::parse(&String::from_utf8_lossy(&b));
    }
}
