//! The C section of `docs/api.md`, enforced on `include/refl.h`: module
//! prefixes, no `params`, an `_options_default(void)` for every options
//! struct, `refl_status` returns, `bool` flags, (pointer, `_len`) pairs,
//! one row-range type, and batch calls that take their single call's
//! arguments in the same order. Each rule is a function returning its
//! violations; every rule has a unit test on a small bad header that shows
//! it fails.

use std::collections::{BTreeMap, BTreeSet};

/// The function and type modules of the C ABI (docs/api.md, "Modules"),
/// with the pass modules of issue 13 and the temporal filter, bounces,
/// extrapolation and upsampling of issue 18.
const MODULES: [&str; 21] = [
    "camera",
    "plane",
    "mirror",
    "image",
    "trace",
    "step",
    "hiz",
    "ssr",
    "cone",
    "layered",
    "cluster",
    "tcrr",
    "epipolar",
    "glossy",
    "planar",
    "summary",
    "plan",
    "temporal",
    "bounce",
    "extrapolate",
    "upsample",
];

/// Library-level functions without a module.
const LIBRARY_FUNCTIONS: [&str; 4] = [
    "refl_version",
    "refl_version_number",
    "refl_status_string",
    "refl_last_error_message",
];

/// Shared vocabulary types without a module (`refl_image_<texel>` and
/// `refl_image_<texel>_mut` are matched by `is_vocabulary`).
const VOCABULARY: [&str; 16] = [
    "refl_vec2",
    "refl_vec3",
    "refl_vec4",
    "refl_mat4",
    "refl_ray",
    "refl_rgba8",
    "refl_camera",
    "refl_plane",
    "refl_status",
    "refl_row_range",
    "refl_depth_convention",
    "refl_projection",
    "refl_depth_image",
    "refl_gbuffer",
    "refl_normal_space",
    "refl_host_ray",
];

/// One parameter or field: its C type (without the name) and its name.
#[derive(Clone, Debug, PartialEq)]
struct Decl {
    ty: String,
    name: String,
    /// The doc comment before a struct field (empty for parameters).
    doc: String,
}

#[derive(Clone, Debug)]
struct Function {
    ret: String,
    name: String,
    params: Vec<Decl>,
}

#[derive(Debug, Default)]
struct Header {
    functions: Vec<Function>,
    structs: BTreeMap<String, Vec<Decl>>,
    enums: BTreeSet<String>,
}

fn squash(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Splits `type name` (`const struct refl_ray *rays`, `float m[16]`).
fn decl(s: &str, doc: &str) -> Decl {
    let s = squash(s);
    let s = match s.find('[') {
        Some(i) => s[..i].trim().to_owned(),
        None => s,
    };
    let at = s
        .rfind(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .map_or(0, |i| i + 1);
    Decl {
        ty: s[..at].trim().to_owned(),
        name: s[at..].to_owned(),
        doc: squash(doc),
    }
}

/// Parses the declarations of a cbindgen header: structs (with their
/// fields' doc comments), enums and function prototypes. Preprocessor
/// lines and the `extern "C"` block lines are dropped.
fn parse(h: &str) -> Header {
    let text: String = h
        .lines()
        .filter(|l| !l.trim_start().starts_with('#') && !l.contains("extern \"C\""))
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n");
    // Top-level items end at `;` outside braces; doc comments are kept
    // apart for struct fields.
    let mut out = Header::default();
    let mut item = String::new();
    let mut depth = 0usize;
    let mut rest = text.as_str();
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix("/*") {
            let end = r.find("*/").map_or(r.len(), |i| i + 2);
            if depth > 0 {
                item.push_str(&rest[..end + 2]);
            }
            rest = &r[end..];
            continue;
        }
        let c = rest.chars().next().unwrap();
        rest = &rest[c.len_utf8()..];
        item.push(c);
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ';' if depth == 0 => {
                add_item(&mut out, &item);
                item.clear();
            }
            _ => {}
        }
    }
    out
}

fn add_item(out: &mut Header, item: &str) {
    let s = item.trim().trim_end_matches(';').trim();
    if let Some(body) = s.strip_prefix("typedef struct ") {
        let (name, rest) = body.split_once('{').unwrap_or((body, ""));
        let fields_text = rest.rsplit_once('}').map_or("", |(f, _)| f);
        let mut fields = Vec::new();
        let mut doc = String::new();
        let mut t = fields_text;
        loop {
            t = t.trim_start();
            if t.is_empty() {
                break;
            }
            if let Some(r) = t.strip_prefix("/*") {
                let end = r.find("*/").unwrap_or(r.len());
                doc = r[..end].replace('*', " ");
                t = &r[(end + 2).min(r.len())..];
                continue;
            }
            let end = t.find(';').unwrap_or(t.len());
            fields.push(decl(&t[..end], &doc));
            doc.clear();
            t = &t[(end + 1).min(t.len())..];
        }
        out.structs.insert(name.trim().to_owned(), fields);
    } else if let Some(body) = s.strip_prefix("enum ") {
        let name = body.split(|c: char| c == '{' || c.is_whitespace()).next();
        out.enums.insert(name.unwrap_or("").to_owned());
    } else if s.starts_with("typedef") || !s.contains('(') {
        // Typedefs of enums; nothing else is declared.
    } else {
        let open = s.find('(').unwrap();
        let close = s.rfind(')').unwrap_or(s.len());
        let head = decl(&s[..open], "");
        let inside = squash(&s[open + 1..close]);
        let params = if inside == "void" || inside.is_empty() {
            Vec::new()
        } else {
            inside.split(',').map(|p| decl(p, "")).collect()
        };
        out.functions.push(Function {
            ret: head.ty,
            name: head.name,
            params,
        });
    }
}

/// The module of a `refl_` name: its first segment after `refl_`, if that
/// is one of `MODULES`.
fn module_of(name: &str) -> Option<&'static str> {
    let rest = name.strip_prefix("refl_")?;
    MODULES
        .iter()
        .find(|m| rest == **m || rest.starts_with(&format!("{m}_")))
        .copied()
}

fn is_vocabulary(t: &str) -> bool {
    if VOCABULARY.contains(&t) {
        return true;
    }
    let Some(texel) = t.strip_prefix("refl_image_") else {
        return false;
    };
    let texel = texel.strip_suffix("_mut").unwrap_or(texel);
    !texel.is_empty() && !texel.contains("__")
}

/// The type named by a declaration's type (`const struct refl_ray *` ->
/// `refl_ray`), if it is one of refl's.
fn refl_type(ty: &str) -> Option<&str> {
    ty.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .find(|w| w.starts_with("refl_"))
}

fn is_pointer(ty: &str) -> bool {
    ty.contains('*')
}

/// Rule "Names": every function is `refl_<module>_<what>` (or one of the
/// library functions), every type `refl_<module>` / `refl_<module>_<what>`
/// or a vocabulary type, and no name says `params`.
fn check_names(h: &Header) -> Vec<String> {
    let mut v = Vec::new();
    for f in &h.functions {
        if !LIBRARY_FUNCTIONS.contains(&f.name.as_str()) && module_of(&f.name).is_none() {
            v.push(format!("function {} has no module prefix", f.name));
        }
        if f.name.contains("params") {
            v.push(format!("function {} says params (Options)", f.name));
        }
        for p in &f.params {
            if p.name.contains("params") {
                v.push(format!("{}: parameter {} says params", f.name, p.name));
            }
        }
    }
    for t in h.structs.keys().chain(&h.enums) {
        if !is_vocabulary(t) && module_of(t).is_none() {
            v.push(format!("type {t} has no module prefix"));
        }
        if t.contains("params") {
            v.push(format!(
                "type {t} says params (options, or input for a bundle)"
            ));
        }
    }
    v
}

/// Rule "Options": every `refl_<module>_..._options` struct has
/// `refl_..._options_default(void)` returning it by value, and every
/// `*_default` function is such a function.
fn check_options(h: &Header) -> Vec<String> {
    let mut v = Vec::new();
    let by_name: BTreeMap<&str, &Function> =
        h.functions.iter().map(|f| (f.name.as_str(), f)).collect();
    for s in h.structs.keys().filter(|s| s.ends_with("_options")) {
        let want = format!("{s}_default");
        match by_name.get(want.as_str()) {
            None => v.push(format!("{s} has no {want}(void)")),
            Some(f) => {
                if !f.params.is_empty() || f.ret != format!("struct {s}") {
                    v.push(format!("{want} must be `struct {s} {want}(void)`"));
                }
            }
        }
    }
    for f in h.functions.iter().filter(|f| f.name.ends_with("_default")) {
        let s = f.name.trim_end_matches("_default");
        if !s.ends_with("_options") || !h.structs.contains_key(s) {
            v.push(format!(
                "{} is not the default of an options struct",
                f.name
            ));
        }
    }
    v
}

/// Rule "Every function returns refl_status" but the library functions
/// and the options defaults.
fn check_returns(h: &Header) -> Vec<String> {
    h.functions
        .iter()
        .filter(|f| {
            f.ret != "refl_status"
                && !LIBRARY_FUNCTIONS.contains(&f.name.as_str())
                && !f.name.ends_with("_options_default")
        })
        .map(|f| format!("{} returns {} (not refl_status)", f.name, f.ret))
        .collect()
}

/// Words in a doc comment that describe a yes/no value.
const FLAG_WORDS: [&str; 6] = [
    "nonzero", "non-zero", "1 if ", "1 for a", "0 or 1", "yes/no",
];

/// Parameter and field names that are yes/no by their form.
fn flag_name(n: &str) -> bool {
    n.starts_with("use_")
        || n.starts_with("is_")
        || n.starts_with("has_")
        || n.ends_with("_check")
        || n.ends_with("_enabled")
        || [
            "enabled",
            "valid",
            "hit",
            "refine",
            "fade",
            "planar",
            "normalize",
            "subpixel",
        ]
        .contains(&n)
}

/// Rule "Flags are bool": no integer field or parameter is a yes/no flag
/// (by name or by its doc comment); an integer holding several bits is
/// named `flags`.
fn check_flags(h: &Header) -> Vec<String> {
    let mut v = Vec::new();
    let integer = |t: &str| matches!(t, "uint32_t" | "int32_t" | "uint8_t" | "int" | "unsigned");
    for (s, fields) in &h.structs {
        for f in fields {
            let doc = f.doc.to_ascii_lowercase();
            let by_doc = FLAG_WORDS.iter().any(|w| doc.contains(w));
            if integer(&f.ty) && f.name != "flags" && (flag_name(&f.name) || by_doc) {
                v.push(format!("{s}.{} is a flag in a {} (bool)", f.name, f.ty));
            }
        }
    }
    for f in &h.functions {
        for p in &f.params {
            if integer(&p.ty) && p.name != "flags" && flag_name(&p.name) {
                v.push(format!("{}: parameter {} is a flag (bool)", f.name, p.name));
            }
        }
    }
    v
}

/// Rule "Buffers are (pointer, `_len`) pairs": every `size_t` parameter is
/// `x_len` right after the pointer `x`, or a `*_bytes` count; no parameter
/// is a `*_count` or `*_size`.
fn check_lengths(h: &Header) -> Vec<String> {
    let mut v = Vec::new();
    for f in &h.functions {
        for (i, p) in f.params.iter().enumerate() {
            if p.name.ends_with("_count") || p.name.ends_with("_size") {
                v.push(format!("{}: {} (a length is x_len)", f.name, p.name));
            }
            if p.ty != "size_t" || p.name.ends_with("_bytes") {
                continue;
            }
            let Some(base) = p.name.strip_suffix("_len") else {
                v.push(format!(
                    "{}: size_t {} is neither _len nor _bytes",
                    f.name, p.name
                ));
                continue;
            };
            let prev = i.checked_sub(1).map(|j| &f.params[j]);
            if !prev.is_some_and(|q| q.name == base && is_pointer(&q.ty)) {
                v.push(format!(
                    "{}: {} does not follow its pointer {base}",
                    f.name, p.name
                ));
            }
        }
    }
    v
}

/// Rule "One row range": row ranges are one `refl_row_range` named `rows`.
fn check_rows(h: &Header) -> Vec<String> {
    let mut v = Vec::new();
    for f in &h.functions {
        for p in &f.params {
            let row_bound = p.name.starts_with("row_")
                && ["begin", "end", "start", "stop", "first", "last", "count"]
                    .iter()
                    .any(|w| p.name.ends_with(w));
            if row_bound {
                v.push(format!(
                    "{}: {} (take a refl_row_range rows)",
                    f.name, p.name
                ));
            }
            if refl_type(&p.ty) == Some("refl_row_range") && !is_pointer(&p.ty) && p.name != "rows"
            {
                v.push(format!("{}: row range named {} (rows)", f.name, p.name));
            }
        }
    }
    v
}

/// Rule "Batch and single calls agree": `refl_x_ys` (batch) takes the
/// arguments of `refl_x_y` (single) in the same order, each per-item
/// argument `a` replaced by `as` / `a` and its `_len`.
fn check_batches(h: &Header) -> Vec<String> {
    let mut v = Vec::new();
    let by_name: BTreeMap<&str, &Function> =
        h.functions.iter().map(|f| (f.name.as_str(), f)).collect();
    for batch in &h.functions {
        let Some(single) = batch.name.strip_suffix('s').and_then(|n| by_name.get(n)) else {
            continue;
        };
        // The batch's arguments with each (pointer, _len) pair collapsed.
        let mut names = Vec::new();
        let mut i = 0;
        while i < batch.params.len() {
            let p = &batch.params[i];
            names.push(p.name.clone());
            let next_is_len = batch
                .params
                .get(i + 1)
                .is_some_and(|q| q.name == format!("{}_len", p.name));
            i += if next_is_len { 2 } else { 1 };
        }
        let single_names: Vec<&str> = single.params.iter().map(|p| p.name.as_str()).collect();
        let same = names.len() == single_names.len()
            && names
                .iter()
                .zip(&single_names)
                .all(|(b, s)| b == s || *b == format!("{s}s"));
        if !same {
            v.push(format!(
                "{} ({}) does not follow {} ({})",
                batch.name,
                names.join(", "),
                single.name,
                single_names.join(", ")
            ));
        }
    }
    v
}

fn header() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../include/refl.h");
    std::fs::read_to_string(path).expect("include/refl.h")
}

fn all_rules(h: &Header) -> Vec<String> {
    [
        check_names(h),
        check_options(h),
        check_returns(h),
        check_flags(h),
        check_lengths(h),
        check_rows(h),
        check_batches(h),
    ]
    .concat()
}

#[test]
fn the_header_follows_docs_api_md() {
    let h = parse(&header());
    assert!(
        h.functions.len() > 90,
        "parsed {} functions",
        h.functions.len()
    );
    assert!(h.structs.len() > 60, "parsed {} structs", h.structs.len());
    let v = all_rules(&h);
    assert!(
        v.is_empty(),
        "{} violations of docs/api.md:\n{}",
        v.len(),
        v.join("\n")
    );
}

#[test]
fn the_parser_reads_structs_enums_and_prototypes() {
    let h = parse(
        "/** A doc with; a semicolon */\n\
         typedef struct refl_cone_x {\n    /** Nonzero: on. */\n    uint32_t on;\n    float m[16];\n} refl_cone_x;\n\
         enum refl_step_kind\n#if defined(__cplusplus)\n  : uint32_t\n#endif\n {\n    REFL_STEP_KIND_A = 0,\n};\n\
         refl_status refl_step_ray(struct refl_trace_result *out,\n                          const float *t_max);\n\
         struct refl_ssr_options refl_ssr_options_default(void);\n",
    );
    let f = &h.structs["refl_cone_x"];
    assert_eq!(
        (f[0].ty.as_str(), f[0].name.as_str(), f[0].doc.as_str()),
        ("uint32_t", "on", "Nonzero: on.")
    );
    assert_eq!((f[1].ty.as_str(), f[1].name.as_str()), ("float", "m"));
    assert!(h.enums.contains("refl_step_kind"));
    assert_eq!(h.functions.len(), 2);
    let p = &h.functions[0].params;
    assert_eq!(
        (p[0].ty.as_str(), p[0].name.as_str()),
        ("struct refl_trace_result *", "out")
    );
    assert_eq!(h.functions[1].ret, "struct refl_ssr_options");
    assert!(h.functions[1].params.is_empty());
}

/// A header that breaks every rule once.
const BAD: &str = "
typedef struct refl_thing { float x; } refl_thing;
typedef struct refl_cone_params { float x; } refl_cone_params;
typedef struct refl_hiz_options { uint32_t levels; } refl_hiz_options;
typedef struct refl_step_options { uint32_t stride; } refl_step_options;
typedef struct refl_cone_flags {
    /** Nonzero: weight by visibility. */
    uint32_t weighting;
    uint32_t use_visibility;
    uint32_t flags;
} refl_cone_flags;
enum refl_other { REFL_OTHER_A = 0, };
refl_status refl_reflect(struct refl_vec3 *out);
refl_status refl_cone_trace(const struct refl_cone_params *params);
refl_status refl_hiz_options_default(struct refl_hiz_options *out);
struct refl_step_options refl_step_options_default(void);
refl_status refl_step_stride_default(void);
uint32_t refl_cone_count(void);
refl_status refl_cluster_x(uint32_t use_cache);
refl_status refl_step_rays_x(const struct refl_ray *rays, size_t ray_count, size_t n);
refl_status refl_hiz_y(float *dst, const float *src, size_t dst_len);
refl_status refl_hiz_build_rows(float *dst, size_t dst_len, uint32_t row_start, uint32_t row_end);
refl_status refl_image_z(struct refl_row_range band);
refl_status refl_step_ray(struct refl_trace_result *out, const struct refl_depth_image *image, struct refl_ray ray, float t_max);
refl_status refl_step_rays(struct refl_trace_result *out, size_t out_len, const struct refl_ray *rays, size_t rays_len, const struct refl_depth_image *image, float t_max);
";

fn has(v: &[String], what: &str) -> bool {
    v.iter().any(|s| s.contains(what))
}

#[test]
fn each_rule_fails_on_a_violation() {
    let h = parse(BAD);
    let names = check_names(&h);
    assert!(has(&names, "function refl_reflect has no module"));
    assert!(has(&names, "type refl_thing has no module"));
    assert!(has(&names, "type refl_other has no module"));
    assert!(has(&names, "type refl_cone_params says params"));
    assert!(has(&names, "parameter params says params"));
    let options = check_options(&h);
    assert!(has(&options, "refl_hiz_options_default must be"));
    assert!(has(&options, "refl_step_stride_default is not the default"));
    assert!(!has(&options, "refl_step_options has no"), "{options:?}");
    let returns = check_returns(&h);
    assert!(has(&returns, "refl_cone_count returns uint32_t"));
    assert!(!has(&returns, "refl_step_options_default"));
    let flags = check_flags(&h);
    assert!(has(&flags, "refl_cone_flags.weighting"));
    assert!(has(&flags, "refl_cone_flags.use_visibility"));
    assert!(!has(&flags, "refl_cone_flags.flags"));
    assert!(has(&flags, "parameter use_cache"));
    let lengths = check_lengths(&h);
    assert!(has(&lengths, "refl_step_rays_x: ray_count"));
    assert!(has(&lengths, "size_t n is neither"));
    assert!(has(
        &lengths,
        "refl_hiz_y: dst_len does not follow its pointer dst"
    ));
    let rows = check_rows(&h);
    assert!(has(&rows, "row_start") && has(&rows, "row_end"));
    assert!(has(&rows, "row range named band"));
    let batches = check_batches(&h);
    assert!(has(&batches, "refl_step_rays (out, rays, image, t_max)"));
    // And a header that follows every rule passes.
    let good = parse(
        "typedef struct refl_step_options { uint32_t stride; bool refine; } refl_step_options;\n\
         struct refl_step_options refl_step_options_default(void);\n\
         const char *refl_version(void);\n\
         refl_status refl_step_ray(struct refl_trace_result *out, const struct refl_depth_image *image, struct refl_ray ray, float t_max);\n\
         refl_status refl_step_rays(struct refl_trace_result *out, size_t out_len, const struct refl_depth_image *image, const struct refl_ray *rays, size_t rays_len, const float *t_max, size_t t_max_len);\n\
         refl_status refl_image_z(void *dst, size_t dst_bytes, struct refl_row_range rows);\n",
    );
    assert_eq!(all_rules(&good), Vec::<String>::new());
}

/// docs/api.md: C's `refl_<module>_options_default()` and Rust's `Default`
/// give the same values. Each C default is converted back to refl-core's
/// type (the conversion the exports use, not the one that built it) and
/// compared with `Default::default()`.
#[test]
fn options_defaults_equal_the_core_defaults() {
    use refl::*;
    use refl_core::cluster::{ClusterCameraOptions, ClusterOptions};
    use refl_core::cone::{ConeOptions, MultiRayOptions};
    use refl_core::epipolar::EpipolarOptions;
    use refl_core::tcrr::TcrrOptions;
    use refl_core::{HiZOptions, LayeredOptions, MirrorMethod, MirrorOptions, StepOptions};
    assert_eq!(
        StepOptions::from(refl_step_options_default()),
        StepOptions::default()
    );
    assert_eq!(
        HiZOptions::from(refl_hiz_options_default()),
        HiZOptions::default()
    );
    assert_eq!(
        ConeOptions::from(refl_cone_options_default()),
        ConeOptions::default()
    );
    assert_eq!(
        MultiRayOptions::from(refl_cone_multiray_options_default()),
        MultiRayOptions::default()
    );
    assert_eq!(
        LayeredOptions::from(refl_layered_options_default()),
        LayeredOptions::default()
    );
    assert_eq!(
        ClusterOptions::from(refl_cluster_options_default()),
        ClusterOptions::default()
    );
    assert_eq!(
        ClusterCameraOptions::from(refl_cluster_camera_options_default()),
        ClusterCameraOptions::default()
    );
    assert_eq!(
        refl_core::cluster::ClusterPassOptions::from(refl_cluster_pass_options_default()),
        refl_core::cluster::ClusterPassOptions::default()
    );
    assert_eq!(
        TcrrOptions::try_from(&refl_tcrr_options_default()),
        Ok(TcrrOptions::default())
    );
    assert_eq!(
        EpipolarOptions::try_from(&refl_epipolar_options_default()),
        Ok(EpipolarOptions::default())
    );
    // The pass's options, field by field.
    let (c, r) = (refl_ssr_options_default(), MirrorOptions::default());
    assert_eq!(c.method, refl_ssr_method::Step as u32);
    assert_eq!(r.method, MirrorMethod::Step);
    assert_eq!(StepOptions::from(c.step), r.step);
    assert_eq!(HiZOptions::from(c.hiz), r.hiz);
    assert_eq!(
        (c.thickness, c.start_pixels, c.t_min, c.t_max),
        (r.thickness, r.start_pixels, r.t_min, r.t_max)
    );
    assert_eq!(
        (c.max_roughness, c.border_fade, c.refine),
        (r.max_roughness, r.border_fade, r.refine)
    );
    assert_eq!(
        (c.reject_back_faces, c.reject_hidden_hits),
        (r.reject_back_faces, r.reject_hidden_hits)
    );
    // The layered pass.
    assert_eq!(
        refl_core::LayeredPassOptions::from(refl_layered_pass_options_default()),
        refl_core::LayeredPassOptions::default()
    );
    // The temporal filter.
    assert_eq!(
        refl_core::temporal::TemporalOptions::from(refl_temporal_options_default()),
        refl_core::temporal::TemporalOptions::default()
    );
    // Bounces, extrapolation, upsampling.
    assert_eq!(
        refl_core::bounce::BounceOptions::from(refl_bounce_options_default()),
        refl_core::bounce::BounceOptions::default()
    );
    assert_eq!(
        refl_core::extrapolate::ExtrapolateOptions::from(refl_extrapolate_options_default()),
        refl_core::extrapolate::ExtrapolateOptions::default()
    );
    assert_eq!(
        refl_core::upsample::UpsampleOptions::from(refl_upsample_options_default()),
        refl_core::upsample::UpsampleOptions::default()
    );
}
