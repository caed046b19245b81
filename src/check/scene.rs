//! The scene builder: reads the root file's `render`, `camera`, `sky`, `medium` and `object`
//! items and fills in the typed scene, reporting unknown, repeated and out-of-range settings.

use super::context::{Checker, duplicate};
use super::suggest::did_you_mean;
use super::value::*;
use crate::diagnostic::Diagnostic;
use crate::scene::print::round9;
use crate::scene::ranges::{self, SettingRange};
use crate::scene::{Camera, Denoise, Object, Quality, RenderSettings, Scene};
use crate::source::{FileId, Span};
use crate::syntax::ast::*;
use std::collections::HashMap;
use std::rc::Rc;

/// Settings of one block by name, each evaluated once; unknown and repeated names reported.
fn settings(
    ck: &mut Checker,
    file: FileId,
    block: &str,
    keys: &[&str],
    items: &[Setting],
) -> HashMap<String, (Value, Span)> {
    let mut out: HashMap<String, (Value, Span)> = HashMap::new();
    let mut first: HashMap<String, Span> = HashMap::new();
    for s in items {
        if !keys.contains(&s.name.name.as_str()) {
            let hint = did_you_mean(&s.name.name, keys.iter().copied());
            ck.error(
                Diagnostic::error(
                    "E0103",
                    format!("`{block}` has no setting `{}`", s.name.name),
                )
                .label(s.name.span, "unknown setting")
                .note(format!("the settings of `{block}` are {}", keys.join(", ")))
                .maybe_help(hint),
            );
            continue;
        }
        if let Some(prev) = first.get(&s.name.name) {
            ck.error(
                Diagnostic::error("E0104", format!("`{}` is set twice", s.name.name))
                    .label(s.name.span, "set again here")
                    .label(*prev, "first set here")
                    .help("remove one of them"),
            );
            continue;
        }
        first.insert(s.name.name.clone(), s.name.span);
        let v = ck.eval(file, &Default::default(), s.value);
        out.insert(s.name.name.clone(), (v, ck.span(file, s.value)));
    }
    out
}

/// A number of `range` (section 13), known at compile time.
fn ranged(ck: &mut Checker, v: &(Value, Span), range: &SettingRange) -> Option<f64> {
    let (v, span) = v;
    let what = range.name;
    if !ck.require_const(v, *span, what) || !ck.expect(v, &Type::Num, *span, what) {
        return None;
    }
    let Value::Num(x) = v else { return None };
    if !range.contains(*x) {
        let must = if range.whole {
            format!("must be {}", range.describe())
        } else {
            format!("must lie in ({}, {}]", Num(range.lo), Num(range.hi))
        };
        ck.error(
            Diagnostic::error("E0301", format!("{what} is out of range"))
                .label(*span, format!("this is {}, but {what} {must}", Num(*x))),
        );
        return None;
    }
    Some(*x)
}

fn choice<T: Copy>(
    ck: &mut Checker,
    v: &(Value, Span),
    what: &str,
    options: &[(&str, T)],
) -> Option<T> {
    let (v, span) = v;
    if !ck.expect(v, &Type::Str, *span, what) {
        return None;
    }
    let Value::Str(s) = v else { return None };
    if let Some((_, t)) = options.iter().find(|(n, _)| **n == **s) {
        return Some(*t);
    }
    let names: Vec<&str> = options.iter().map(|(n, _)| *n).collect();
    let hint = did_you_mean(s, names.iter().copied());
    ck.error(
        Diagnostic::error("E0301", format!("unknown {what} \"{s}\""))
            .label(
                *span,
                format!(
                    "expected one of {}",
                    names
                        .iter()
                        .map(|n| format!("\"{n}\""))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
            .maybe_help(hint),
    );
    None
}

fn vec4(ck: &mut Checker, v: &(Value, Span), what: &str) -> Option<[f64; 4]> {
    let (v, span) = v;
    if !ck.expect(v, &Type::Vec4, *span, what) || !ck.require_const(v, *span, what) {
        return None;
    }
    match v {
        Value::Vec4(a) => Some(*a),
        _ => None,
    }
}

pub fn build(ck: &mut Checker, root: FileId) -> Scene {
    let ast = ck.ast(root);
    let mut render = RenderSettings::default();
    let mut camera = Camera {
        from: [0.0, 0.0, -4.0, 0.0],
        to: [0.0, 0.0, -4.0, 0.0],
        look: vec![],
        fov: 60f64.to_radians(),
    };
    let mut sky = [0.0; 3];
    let mut medium = Material::Air;
    let mut objects: Vec<Object> = vec![];
    let mut seen_blocks: HashMap<&str, Span> = HashMap::new();
    let mut object_names: HashMap<String, Span> = HashMap::new();

    for item in &ast.items {
        let key = match &item.kind {
            ItemKind::Block { kind, .. } => Some(kind.keyword()),
            ItemKind::Sky(_) => Some("sky"),
            ItemKind::Medium(_) => Some("medium"),
            _ => None,
        };
        if let Some(key) = key {
            let head = Span {
                end: item.span.start + key.len() as u32,
                ..item.span
            };
            if let Some(prev) = seen_blocks.get(key) {
                ck.error(
                    Diagnostic::error("E0104", format!("`{key}` is given twice"))
                        .label(head, "given again here")
                        .label(*prev, "first given here")
                        .help("a scene has one of each; merge the two"),
                );
                continue;
            }
            seen_blocks.insert(key, head);
        }
        match &item.kind {
            ItemKind::Block {
                kind: BlockKind::Render,
                settings: items,
            } => {
                let s = settings(ck, root, "render", BlockKind::Render.settings(), items);
                if let Some(q) = s.get("quality") {
                    let opts = [
                        ("draft", Quality::Draft),
                        ("preview", Quality::Preview),
                        ("final", Quality::Final),
                        ("custom", Quality::Custom),
                    ];
                    if let Some(q) = choice(ck, q, "quality", &opts) {
                        q.apply(&mut render);
                    }
                }
                if let Some((v, span)) = s.get("size")
                    && ck.require_const(v, *span, "the image size")
                    && ck.expect(v, &Type::Size, *span, "the image size")
                    && let Value::Size(w, h) = v
                {
                    if ranges::SIDE.contains(*w) && ranges::SIDE.contains(*h) {
                        (render.width, render.height) = (*w as u32, *h as u32);
                    } else {
                        ck.error(Diagnostic::error("E0301", "image size out of range").label(
                            *span,
                            format!(
                                "this is {} x {}, but each side must be {}",
                                Num(*w),
                                Num(*h),
                                ranges::SIDE.describe()
                            ),
                        ));
                    }
                }
                let u = |ck: &mut Checker, range: &SettingRange| {
                    s.get(range.name).and_then(|v| ranged(ck, v, range))
                };
                if let Some(x) = u(ck, &ranges::FRAMES) {
                    render.frames = x as u32;
                }
                if let Some(x) = u(ck, &ranges::SPP) {
                    render.spp = x as u32;
                }
                if let Some(x) = u(ck, &ranges::BOUNCES) {
                    render.bounces = x as u32;
                }
                if let Some(x) = u(ck, &ranges::MAX_STEPS) {
                    render.max_steps = x as u32;
                }
                if let Some(x) = u(ck, &ranges::SEED) {
                    render.seed = x as u64;
                }
                if let Some(x) = u(ck, &ranges::THREADS) {
                    render.threads = x as u32;
                }
                if let Some(x) = u(ck, &ranges::EPSILON) {
                    render.epsilon = x;
                }
                if let Some(x) = u(ck, &ranges::FPS) {
                    render.fps = x;
                }
                if let Some(x) = u(ck, &ranges::EXPOSURE) {
                    render.exposure = x;
                }
                if let Some(d) = s.get("denoise") {
                    let opts = Denoise::ALL.map(|d| (d.name(), d));
                    if let Some(d) = choice(ck, d, "denoiser", &opts) {
                        render.denoise = d;
                    }
                }
            }
            ItemKind::Block {
                kind: BlockKind::Camera,
                settings: items,
            } => {
                let s = settings(ck, root, "camera", BlockKind::Camera.settings(), items);
                if let Some(v) = s
                    .get("from")
                    .and_then(|v| vec4(ck, v, "the camera's `from`"))
                {
                    camera.from = v;
                    camera.to = v;
                }
                if let Some(v) = s.get("to").and_then(|v| vec4(ck, v, "the camera's `to`")) {
                    camera.to = v;
                }
                if let Some((v, span)) = s.get("look")
                    && ck.expect(v, &Type::Rotation, *span, "the camera's `look`")
                    && let Value::Rotation(r) = v
                {
                    let deps = ck.deps(v);
                    if deps & (DEP_P | DEP_N) != 0 {
                        ck.require_const(v, *span, "the camera's `look`");
                    }
                    camera.look = r.to_vec();
                }
                if let Some((v, span)) = s.get("fov")
                    && ck.require_const(v, *span, "the field of view")
                    && ck.expect(v, &Type::Angle, *span, "the field of view")
                    && let Value::Angle(a) = v
                {
                    if *a > 0.0 && *a < std::f64::consts::PI {
                        camera.fov = *a;
                    } else {
                        ck.error(
                            Diagnostic::error("E0301", "field of view out of range")
                                .label(*span, format!("this is {}deg, but it must lie strictly between 0deg and 180deg", Num(round9(a.to_degrees())))),
                        );
                    }
                }
            }
            ItemKind::Sky(e) => {
                let v = ck.eval(root, &Default::default(), *e);
                let span = ck.span(root, *e);
                let v = super::ops::coerce(ck, v, &Type::Color);
                if ck.expect(&v, &Type::Color, span, "the sky")
                    && ck.require_const(&v, span, "the sky")
                    && let Value::Color(c) = v
                {
                    if c.iter().all(|x| *x >= 0.0) {
                        sky = c;
                    } else {
                        ck.error(
                            Diagnostic::error("E0301", "the sky cannot be negative")
                                .label(span, "a radiance is at least 0"),
                        );
                    }
                }
            }
            ItemKind::Medium(e) => {
                let v = ck.eval(root, &Default::default(), *e);
                let span = ck.span(root, *e);
                if ck.expect(&v, &Type::Material, span, "the medium")
                    && ck.require_const(&v, span, "the medium")
                {
                    match v {
                        Value::Material(m)
                            if matches!(m.kind(), MaterialKind::Fog | MaterialKind::Air) =>
                        {
                            medium = (*m).clone()
                        }
                        Value::Material(m) => {
                            ck.error(
                                Diagnostic::error(
                                    "E0201",
                                    format!(
                                        "the medium must be `fog(...)` or `air`, not `{}`",
                                        m.kind().name()
                                    ),
                                )
                                .label(span, "this material is a surface, not a volume")
                                .help("write `medium = fog(extinction: 0.1)`"),
                            );
                        }
                        _ => {}
                    }
                }
            }
            ItemKind::Object {
                name,
                settings: items,
            } => {
                if let Some(prev) = object_names.get(&name.name) {
                    ck.error(duplicate(name, *prev));
                    continue;
                }
                object_names.insert(name.name.clone(), name.span);
                if let Some(o) = object(ck, root, name, items, item.span) {
                    objects.push(o);
                }
            }
            _ => {}
        }
    }
    if ast
        .items
        .iter()
        .all(|i| !matches!(i.kind, ItemKind::Object { .. }))
    {
        ck.diags.push(
            Diagnostic::warning("W0004", "the scene has no objects")
                .label(Span::new(root, 0, 0), "nothing to render in this file")
                .help("add one, as in `object ball { shape = hypersphere(1) }`"),
        );
    }
    if !objects.is_empty()
        && sky.iter().all(|x| *x == 0.0)
        && !ck.diags.iter().any(|d| d.is_error())
        && !objects.iter().any(|o| may_emit(&ck.fields, &o.material))
    {
        // Certain that nothing gives off light: every picture would be black.
        ck.diags.push(
            Diagnostic::warning("W0005", "nothing in the scene gives off light")
                .label(
                    Span::new(root, 0, 0),
                    "every frame of this scene renders black",
                )
                .note(
                    "the sky is black (the default), no object is a `light(...)` and no \
                     `diffuse` has an `emission`",
                )
                .help(
                    "add a light, an emission, or a sky colour, as in \
                     `sky = rgb(0.6, 0.7, 0.9)` or `material = light(intensity: 5)`",
                ),
        );
    }
    let fields = std::mem::take(&mut ck.fields);
    Scene {
        render,
        camera,
        sky,
        medium,
        objects,
        fields,
    }
}

fn object(
    ck: &mut Checker,
    root: FileId,
    name: &Ident,
    items: &[Setting],
    span: Span,
) -> Option<Object> {
    let s = settings(ck, root, "object", &OBJECT_SETTINGS, items);
    let Some((shape, sspan)) = s.get("shape") else {
        ck.error(
            Diagnostic::error("E0105", format!("object `{}` has no shape", name.name))
                .label(name.span, "this object needs `shape = ...`")
                .help("add a shape, as in `shape = hypersphere(radius: 1)`"),
        );
        return None;
    };
    if !ck.expect(shape, &Type::Shape, *sspan, "an object's shape") {
        return None;
    }
    let Value::Shape(shape) = shape.clone() else {
        return None;
    };
    let material = match s.get("material") {
        None => Value::Material(Rc::new(Material::with_defaults(MaterialKind::Diffuse))),
        Some((Value::Function(f), mspan)) => {
            if let Function::Lambda { params, .. } = &**f
                && params.len() != 2
            {
                let heads = params.first().map_or(*mspan, |p| p.span);
                let heads = params.last().map_or(heads, |p| heads.to(p.span));
                let names: Vec<&str> = params.iter().map(|p| p.name.as_str()).collect();
                ck.error(
                    Diagnostic::error("E0202", "a material map takes `|p, n|`")
                        .label(
                            heads,
                            format!(
                                "this takes {} parameter{}",
                                params.len(),
                                super::context::plural(params.len())
                            ),
                        )
                        .note("a material map is called with the hit point `p` and the surface normal `n`")
                        .help(match names.as_slice() {
                            [p] => format!("write `|{p}, n| ...`, and ignore `n` if you do not need it"),
                            _ => "write `|p, n| ...`".to_string(),
                        }),
                );
                return None;
            }
            let p = ck.field(FieldOp::Input(Input::P), Type::Vec4);
            let n = ck.field(FieldOp::Input(Input::N), Type::Vec4);
            let args = [p, n]
                .map(|value| ArgVal {
                    name: None,
                    value,
                    span: *mspan,
                })
                .to_vec();
            let v = ck.call(&Value::Function(f.clone()), args, *mspan, *mspan);
            if !ck.expect(&v, &Type::Material, *mspan, "a material map's result") {
                return None;
            }
            v
        }
        Some((v, mspan)) => {
            if !ck.expect(v, &Type::Material, *mspan, "an object's material") {
                return None;
            }
            v.clone()
        }
    };
    if matches!(&material, Value::Material(m) if m.kind() == MaterialKind::Air)
        && shape.bounds().is_some()
    {
        // An object of clear air with no medium cannot be seen; say so rather than render nothing.
        ck.diags.push(
            Diagnostic::warning("W0003", format!("object `{}` can never be seen", name.name))
                .label(
                    span,
                    "its material is `air`, which neither scatters nor absorbs",
                )
                .help("use `fog(...)` for a visible volume, or remove the object"),
        );
    }
    let material = match material {
        Value::Material(m) => crate::scene::Param::Const(m),
        Value::Field(id, _) => crate::scene::Param::Field(id),
        _ => return None,
    };
    Some(Object {
        name: name.name.clone(),
        span,
        shape,
        material,
    })
}

/// Whether a material may give off light: `false` only when that is certain (a field that is
/// not a choice between constant materials may emit).
fn may_emit(fields: &Fields, material: &crate::scene::Param<Rc<Material>>) -> bool {
    match material {
        crate::scene::Param::Const(m) => material_may_emit(fields, m),
        crate::scene::Param::Field(id) => field_may_emit(fields, *id),
    }
}

fn field_may_emit(fields: &Fields, id: FieldId) -> bool {
    match &fields.get(id).op {
        FieldOp::Const(Const::Material(m)) => material_may_emit(fields, m),
        FieldOp::Select(_, a, b) => field_may_emit(fields, *a) || field_may_emit(fields, *b),
        FieldOp::Index(xs, _) => xs.iter().any(|x| field_may_emit(fields, *x)),
        _ => true,
    }
}

fn material_may_emit(fields: &Fields, m: &Material) -> bool {
    let black = |c: &crate::scene::Param<[f64; 3]>| match c {
        crate::scene::Param::Const(c) => c.iter().all(|x| *x == 0.0),
        crate::scene::Param::Field(id) => {
            matches!(&fields.get(*id).op, FieldOp::Const(Const::Color(c)) if c.iter().all(|x| *x == 0.0))
        }
    };
    match m {
        Material::Diffuse { emission, .. } => !black(emission),
        Material::Light { color, intensity } => {
            !(black(color) || matches!(intensity, crate::scene::Param::Const(x) if *x == 0.0))
        }
        _ => false,
    }
}
