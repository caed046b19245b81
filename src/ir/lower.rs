//! Lowering: the typed scene's shapes, custom distances and material maps become nodes of one
//! graph. Nothing is optimised here beyond interning; `opt` does that, so the plain lowered
//! graph is the reference the optimised bytecode is tested against.

use super::{Bin, Graph, Id, K, Node, Un, Var};
use crate::math::Plane;
use crate::math::plane::rotation as rotation_matrix;
use crate::scene::field::{DEP_N, DEP_P};
use crate::scene::shape::{Num, Vector};
use crate::scene::{
    Const, FieldBin, FieldId, FieldOp, Fields, Input, Lattice, Material, MaterialKind, MathFn,
    Object, Param, Polytope, Scene, Shape, ShapeKind, Slot,
};
use std::collections::HashMap;

/// The lowered scene: one graph, with roots for each object and for the whole scene.
#[derive(Clone, Debug)]
pub struct SceneIr {
    pub graph: Graph,
    pub objects: Vec<ObjectIr>,
    /// The distance to the nearest visible object, and that object's index.
    pub distance: Id,
    pub nearest: Id,
    /// The camera orientation: plane rotations whose angles may depend on `t`.
    pub look: Vec<(Plane, Id)>,
    /// `min |d_i|` over the visible objects and its argmin, for rays inside objects; present
    /// when some object can be entered (glass, fog or air).
    pub interior: Option<(Id, Id)>,
    /// The spherical emitters, for light sampling.
    pub lights: Vec<LightIr>,
}

/// A spherical light: object `object` is a hypersphere of radius `radius` under `places`
/// (outermost first), with a constant `light` material.
#[derive(Clone, Debug)]
pub struct LightIr {
    pub object: usize,
    pub places: Vec<Place>,
    pub radius: Id,
}

/// One shape operation around a light's hypersphere; parameters are roots of the graph.
#[derive(Clone, Debug)]
pub enum Place {
    Translate([Id; 4]),
    Rotate(Vec<(Plane, Id)>),
    Scale(Id),
    Round(Id),
}

impl LightIr {
    /// Every node the placement reads.
    pub fn ids(&self) -> Vec<Id> {
        let mut out = vec![self.radius];
        for p in &self.places {
            match p {
                Place::Translate(v) => out.extend(v),
                Place::Rotate(steps) => out.extend(steps.iter().map(|(_, a)| *a)),
                Place::Scale(k) | Place::Round(k) => out.push(*k),
            }
        }
        out
    }

    fn map(&self, f: &mut impl FnMut(Id) -> Id) -> LightIr {
        let places = (self.places.iter())
            .map(|p| match p {
                Place::Translate(v) => Place::Translate(v.map(&mut *f)),
                Place::Rotate(steps) => {
                    Place::Rotate(steps.iter().map(|(pl, a)| (*pl, f(*a))).collect())
                }
                Place::Scale(k) => Place::Scale(f(*k)),
                Place::Round(r) => Place::Round(f(*r)),
            })
            .collect();
        LightIr {
            object: self.object,
            places,
            radius: f(self.radius),
        }
    }
}

#[derive(Clone, Debug)]
pub struct ObjectIr {
    pub name: String,
    pub distance: Id,
    pub material: MaterialIr,
}

/// A material map: `selector` picks one of `leaves` (as 0, 1, ...) at a hit point.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialIr {
    pub selector: Id,
    pub leaves: Vec<Leaf>,
}

/// One material of a map, with each number as one node and each colour as three.
pub type Leaf = Material<Id, [Id; 3]>;

impl MaterialIr {
    /// Every node a material map reads, for liveness and tape outputs: the selector, then each
    /// leaf's parameters in order.
    pub fn roots(&self) -> Vec<Id> {
        let mut out = vec![self.selector];
        for l in &self.leaves {
            for p in l.params() {
                match p {
                    Slot::Num(x) => out.push(*x),
                    Slot::Color(c) => out.extend(c),
                }
            }
        }
        out
    }

    /// The same map with every node renamed.
    pub fn map(&self, f: &mut impl FnMut(Id) -> Id) -> MaterialIr {
        MaterialIr {
            selector: f(self.selector),
            leaves: (self.leaves.iter())
                .map(|l| {
                    l.convert(|p| match p {
                        Slot::Num(x) => Slot::Num(f(*x)),
                        Slot::Color(c) => Slot::Color(c.map(&mut *f)),
                    })
                })
                .collect(),
        }
    }

    /// Whether this is plain `air` everywhere.
    pub fn is_air(&self) -> bool {
        self.leaves.iter().all(|l| l.kind() == MaterialKind::Air)
    }

    /// Whether some leaf can be entered (glass, fog or air).
    pub fn has_interior(&self) -> bool {
        self.leaves.iter().any(|l| l.kind().has_interior())
    }
}

impl SceneIr {
    /// Every root of the scene, in a fixed order: scene distance, nearest, then per object its
    /// distance and material nodes, then the camera angles.
    pub fn roots(&self) -> Vec<Id> {
        let mut out = vec![self.distance, self.nearest];
        for o in &self.objects {
            out.push(o.distance);
            out.extend(o.material.roots());
        }
        out.extend(self.look.iter().map(|(_, a)| *a));
        if let Some((d, n)) = self.interior {
            out.extend([d, n]);
        }
        for l in &self.lights {
            out.extend(l.ids());
        }
        out
    }

    /// The same scene over a new graph, with every root renamed by `f`.
    pub fn remap(&self, graph: Graph, f: &mut impl FnMut(Id) -> Id) -> SceneIr {
        SceneIr {
            distance: f(self.distance),
            nearest: f(self.nearest),
            objects: self
                .objects
                .iter()
                .map(|o| ObjectIr {
                    name: o.name.clone(),
                    distance: f(o.distance),
                    material: o.material.map(f),
                })
                .collect(),
            look: self.look.iter().map(|(p, a)| (*p, f(*a))).collect(),
            interior: self.interior.map(|(d, n)| (f(d), f(n))),
            lights: self.lights.iter().map(|l| l.map(f)).collect(),
            graph,
        }
    }
}

/// A lowered value: a scalar (numbers, angles and booleans as 1/0), a vector, a colour or a
/// material map.
#[derive(Clone, Debug)]
enum Lv {
    S(Id),
    V([Id; 4]),
    C([Id; 3]),
    M(MaterialIr),
}

impl Lv {
    fn lanes(&self) -> Vec<Id> {
        match self {
            Lv::S(a) => vec![*a],
            Lv::V(v) => v.to_vec(),
            Lv::C(c) => c.to_vec(),
            Lv::M(m) => vec![m.selector],
        }
    }

    /// The same shape of value with other lanes.
    fn with(&self, ids: Vec<Id>) -> Lv {
        match self {
            Lv::S(_) => Lv::S(ids[0]),
            Lv::V(_) => Lv::V([ids[0], ids[1], ids[2], ids[3]]),
            Lv::C(_) => Lv::C([ids[0], ids[1], ids[2]]),
            Lv::M(_) => unreachable!("materials are combined by `choose`"),
        }
    }
}

/// What `p` and `n` stand for while lowering a field.
#[derive(Clone, Copy)]
struct Env {
    p: [Id; 4],
    n: [Id; 4],
}

struct Lower<'a> {
    g: Graph,
    fields: &'a Fields,
    memo: HashMap<(FieldId, [Id; 4]), Lv>,
}

/// Lower a checked scene.
pub fn lower(scene: &Scene) -> SceneIr {
    let mut l = Lower {
        g: Graph::new(),
        fields: &scene.fields,
        memo: HashMap::new(),
    };
    let p = Var::POINT.map(|v| l.g.intern(Node::Var(v)));
    let n = Var::NORMAL.map(|v| l.g.intern(Node::Var(v)));
    let env = Env { p, n };
    let mut objects = vec![];
    for o in &scene.objects {
        let distance = l.shape(&o.shape, p);
        let material = match &o.material {
            Param::Const(m) => l.material(m, env),
            Param::Field(id) => match l.field(*id, env) {
                Lv::M(m) => m,
                other => unreachable!("the checker types a material map: {other:?}"),
            },
        };
        objects.push(ObjectIr {
            name: o.name.clone(),
            distance,
            material,
        });
    }
    let (distance, nearest) = l.nearest(&objects, |_, d| d);
    let look = (scene.camera.look.iter())
        .map(|(plane, a)| (*plane, l.num(a, env)))
        .collect();
    let interior = (objects.iter().any(|o| o.material.has_interior()))
        .then(|| l.nearest(&objects, |l, d| l.un(Un::Abs, d)));
    let lights = (scene.objects.iter().enumerate())
        .filter_map(|(i, o)| l.light(i, o, env))
        .collect();
    SceneIr {
        graph: l.g,
        objects,
        distance,
        nearest,
        look,
        interior,
        lights,
    }
}

/// The objects rays can meet (not air), as (object index, distance).
pub fn visible(objects: &[ObjectIr]) -> impl Iterator<Item = (usize, Id)> + '_ {
    (objects.iter().enumerate())
        .filter(|(_, o)| !o.material.is_air())
        .map(|(i, o)| (i, o.distance))
}

/// The smallest of the distances `ds` (object index, distance) and its object's index (-1
/// for none), as a running min-with-id.
pub fn nearest(g: &mut Graph, ds: &[(usize, Id)]) -> (Id, Id) {
    let (mut best, mut id) = (
        g.intern(Node::Const(K::new(f64::INFINITY))),
        g.intern(Node::Const(K::new(-1.0))),
    );
    for &(i, d) in ds {
        let t = g.intern(Node::MinId(best, id, d, K::new(i as f64)));
        best = g.intern(Node::Proj(t, 0));
        id = g.intern(Node::Proj(t, 1));
    }
    (best, id)
}

impl Lower<'_> {
    fn k(&mut self, x: f64) -> Id {
        self.g.intern(Node::Const(K::new(x)))
    }
    fn un(&mut self, op: Un, a: Id) -> Id {
        self.g.intern(Node::Un(op, a))
    }
    fn bin(&mut self, op: Bin, a: Id, b: Id) -> Id {
        self.g.intern(Node::Bin(op, a, b))
    }
    fn t(&mut self) -> Id {
        self.g.intern(Node::Var(Var::T))
    }

    /// The nearest visible object's `distance(d_i)` (a min over objects, with its index).
    fn nearest(
        &mut self,
        objects: &[ObjectIr],
        mut distance: impl FnMut(&mut Self, Id) -> Id,
    ) -> (Id, Id) {
        let ds: Vec<(usize, Id)> = (visible(objects))
            .map(|(i, d)| (i, distance(self, d)))
            .collect();
        nearest(&mut self.g, &ds)
    }

    /// Object `i` as a spherical light, if its material is a constant `light` and its shape a
    /// hypersphere under translations, rotations, positive scales and roundings.
    fn light(&mut self, i: usize, o: &Object, env: Env) -> Option<LightIr> {
        match &o.material {
            Param::Const(m) if m.kind() == MaterialKind::Light => {}
            _ => return None,
        }
        if o.material_deps(self.fields) & (DEP_P | DEP_N) != 0 {
            return None;
        }
        let mut places = vec![];
        let mut s = &o.shape;
        loop {
            let place = match &s.kind {
                ShapeKind::Hypersphere { radius } => {
                    let radius = self.num(radius, env);
                    return Some(LightIr {
                        object: i,
                        places,
                        radius,
                    });
                }
                ShapeKind::Translate { shape, offset } => {
                    s = shape;
                    Place::Translate(self.vector(offset, env))
                }
                ShapeKind::Scale { shape, factor } => {
                    s = shape;
                    Place::Scale(self.num(factor, env))
                }
                ShapeKind::Round { shape, radius } => {
                    s = shape;
                    Place::Round(self.num(radius, env))
                }
                ShapeKind::Rotate { shape, rotation } => {
                    s = shape;
                    let steps = rotation.iter().map(|(p, a)| (*p, self.num(a, env)));
                    Place::Rotate(steps.collect())
                }
                _ => return None,
            };
            places.push(place);
        }
    }

    fn scalar(&mut self, v: Lv) -> Id {
        match v {
            Lv::S(a) => a,
            other => other.lanes()[0],
        }
    }

    fn num(&mut self, v: &Num, env: Env) -> Id {
        match v {
            Param::Const(x) => self.k(*x),
            Param::Field(id) => {
                let v = self.field(*id, env);
                self.scalar(v)
            }
        }
    }

    fn vector(&mut self, v: &Vector, env: Env) -> [Id; 4] {
        self.lanes(v, env)
    }

    fn color(&mut self, c: &Param<[f64; 3]>, env: Env) -> [Id; 3] {
        self.lanes(c, env)
    }

    /// A vector or colour parameter as its `N` lanes; a scalar field is broadcast.
    fn lanes<const N: usize>(&mut self, v: &Param<[f64; N]>, env: Env) -> [Id; N] {
        match v {
            Param::Const(v) => v.map(|x| self.k(x)),
            Param::Field(id) => match self.field(*id, env) {
                Lv::S(a) => [a; N],
                other => {
                    let l = other.lanes();
                    std::array::from_fn(|i| l[i.min(l.len() - 1)])
                }
            },
        }
    }

    fn constant(&mut self, c: &Const, env: Env) -> Lv {
        match c {
            Const::Num(x) | Const::Angle(x) => Lv::S(self.k(*x)),
            Const::Bool(b) => Lv::S(self.k(if *b { 1.0 } else { 0.0 })),
            Const::Vec4(v) => Lv::V(v.map(|x| self.k(x))),
            Const::Color(c) => Lv::C(c.map(|x| self.k(x))),
            Const::Material(m) => Lv::M(self.material(m, env)),
        }
    }

    fn material(&mut self, m: &Material, env: Env) -> MaterialIr {
        let leaf = m.convert(|p| match p {
            Slot::Num(x) => Slot::Num(self.num(x, env)),
            Slot::Color(c) => Slot::Color(self.color(c, env)),
        });
        MaterialIr {
            selector: self.k(0.0),
            leaves: vec![leaf],
        }
    }

    fn field(&mut self, id: FieldId, env: Env) -> Lv {
        if let Some(v) = self.memo.get(&(id, env.p)) {
            return v.clone();
        }
        let node = self.fields.get(id);
        let v = match &node.op {
            FieldOp::Input(Input::P) => Lv::V(env.p),
            FieldOp::Input(Input::N) => Lv::V(env.n),
            FieldOp::Input(Input::T) => Lv::S(self.t()),
            FieldOp::Const(c) => self.constant(c, env),
            FieldOp::Unary(op, a) => {
                let a = self.field(*a, env);
                let ids = a.lanes().iter().map(|x| self.un(*op, *x)).collect();
                a.with(ids)
            }
            FieldOp::Binary(op, a, b) => {
                let (a, b) = (self.field(*a, env), self.field(*b, env));
                self.binary(*op, a, b)
            }
            FieldOp::Math(f, args) => {
                let args: Vec<Lv> = args.iter().map(|a| self.field(*a, env)).collect();
                self.math(*f, args)
            }
            FieldOp::Component(a, i) => Lv::S(self.field(*a, env).lanes()[*i as usize]),
            FieldOp::MakeVec4(xs) => Lv::V(xs.map(|x| self.field(x, env).lanes()[0])),
            FieldOp::MakeColor(xs) => Lv::C(xs.map(|x| self.field(x, env).lanes()[0])),
            FieldOp::Select(c, a, b) => {
                let c = self.field(*c, env).lanes()[0];
                let (a, b) = (self.field(*a, env), self.field(*b, env));
                self.choose(c, b, a)
            }
            FieldOp::Index(items, i) => {
                // The index rounds down and is clamped to the list.
                let i = self.field(*i, env).lanes()[0];
                let i = self.un(Un::Floor, i);
                let mut out = self.field(items[0], env);
                for (k, item) in items.iter().enumerate().skip(1) {
                    let kk = self.k(k as f64);
                    let c = self.bin(Bin::Le, kk, i);
                    let item = self.field(*item, env);
                    out = self.choose(c, out, item);
                }
                out
            }
            FieldOp::Cell(lat, p) => {
                let p = self.field(*p, env).lanes();
                Lv::V(self.cell(lat, [p[0], p[1], p[2], p[3]]).1)
            }
        };
        self.memo.insert((id, env.p), v.clone());
        v
    }

    /// `if c { yes } else { no }` on any value; materials merge their leaves.
    fn choose(&mut self, c: Id, no: Lv, yes: Lv) -> Lv {
        match (no, yes) {
            (Lv::M(no), Lv::M(yes)) => {
                let offset = self.k(no.leaves.len() as f64);
                let shifted = self.bin(Bin::Add, yes.selector, offset);
                let selector = self.g.intern(Node::Select(c, shifted, no.selector));
                let mut leaves = no.leaves;
                leaves.extend(yes.leaves);
                Lv::M(MaterialIr { selector, leaves })
            }
            (no, yes) => {
                let ids = (no.lanes().iter().zip(yes.lanes()))
                    .map(|(n, y)| self.g.intern(Node::Select(c, y, *n)))
                    .collect();
                no.with(ids)
            }
        }
    }

    /// Lanes of `a op b`, broadcasting a scalar against a vector or colour.
    fn zip(&mut self, op: Bin, a: &Lv, b: &Lv) -> Lv {
        let (la, lb) = (a.lanes(), b.lanes());
        let n = la.len().max(lb.len());
        let get = |l: &[Id], i: usize| if l.len() == 1 { l[0] } else { l[i] };
        let ids = (0..n)
            .map(|i| self.bin(op, get(&la, i), get(&lb, i)))
            .collect();
        if la.len() >= lb.len() {
            a.with(ids)
        } else {
            b.with(ids)
        }
    }

    fn binary(&mut self, op: FieldBin, a: Lv, b: Lv) -> Lv {
        let reduce = |l: &mut Self, op: Bin, ids: Vec<Id>| {
            ids.into_iter()
                .reduce(|x, y| l.bin(op, x, y))
                .expect("a value has lanes")
        };
        match op {
            FieldBin::Add => self.zip(Bin::Add, &a, &b),
            FieldBin::Sub => self.zip(Bin::Sub, &a, &b),
            FieldBin::Mul => self.zip(Bin::Mul, &a, &b),
            FieldBin::Div => self.zip(Bin::Div, &a, &b),
            FieldBin::Mod => self.zip(Bin::Mod, &a, &b),
            FieldBin::Lt => self.zip(Bin::Lt, &a, &b),
            FieldBin::Le => self.zip(Bin::Le, &a, &b),
            FieldBin::Gt => self.zip(Bin::Lt, &b, &a),
            FieldBin::Ge => self.zip(Bin::Le, &b, &a),
            FieldBin::And => self.zip(Bin::And, &a, &b),
            FieldBin::Or => self.zip(Bin::Or, &a, &b),
            FieldBin::Eq => {
                let eq = self.zip(Bin::Eq, &a, &b).lanes();
                Lv::S(reduce(self, Bin::And, eq))
            }
            FieldBin::Ne => {
                let ne = self.zip(Bin::Ne, &a, &b).lanes();
                Lv::S(reduce(self, Bin::Or, ne))
            }
        }
    }

    fn math(&mut self, f: MathFn, args: Vec<Lv>) -> Lv {
        let map = |l: &mut Self, op: Un, a: &Lv| {
            let ids = a.lanes().iter().map(|x| l.un(op, *x)).collect();
            a.with(ids)
        };
        let a = &args[0];
        match f {
            MathFn::Un(op) => map(self, op, a),
            MathFn::Bin(op) => self.zip(op, a, &args[1]),
            MathFn::Clamp => {
                let lo = self.zip(Bin::Max, a, &args[1]);
                self.zip(Bin::Min, &lo, &args[2])
            }
            MathFn::Mix => {
                let d = self.zip(Bin::Sub, &args[1], a);
                let d = self.zip(Bin::Mul, &d, &args[2]);
                self.zip(Bin::Add, a, &d)
            }
            MathFn::Length => Lv::S(self.length(a)),
            MathFn::Dot => {
                let p = self.zip(Bin::Mul, a, &args[1]).lanes();
                Lv::S(self.sum(&p))
            }
            MathFn::Normalize => {
                let len = Lv::S(self.length(a));
                self.zip(Bin::Div, a, &len)
            }
        }
    }

    fn length(&mut self, a: &Lv) -> Id {
        let mut l = a.lanes();
        let zero = self.k(0.0);
        l.resize(4, zero);
        self.g
            .intern(Node::Length([l[0], l[1], l[2], l[3]], [K::new(0.0); 5]))
    }

    fn sum(&mut self, xs: &[Id]) -> Id {
        let mut acc = xs[0];
        for x in &xs[1..] {
            acc = self.bin(Bin::Add, acc, *x);
        }
        acc
    }

    /// A point mapped by `m * p + b` (each row one `Affine` node).
    fn affine(&mut self, p: [Id; 4], m: [[f64; 4]; 4], b: [f64; 4]) -> [Id; 4] {
        std::array::from_fn(|i| {
            let row = [m[i][0], m[i][1], m[i][2], m[i][3], b[i]].map(K::new);
            self.g.intern(Node::Affine(p, row))
        })
    }

    fn diag(&mut self, p: [Id; 4], s: [f64; 4]) -> [Id; 4] {
        let mut m = [[0.0; 4]; 4];
        for i in 0..4 {
            m[i][i] = s[i];
        }
        self.affine(p, m, [0.0; 4])
    }

    /// The offset of `p` from its lattice point (in world units) and the lattice cell.
    fn cell(&mut self, lat: &Lattice, p: [Id; 4]) -> ([Id; 4], [Id; 4]) {
        match lat {
            Lattice::D4 { scale } => {
                let q = self.diag(p, [1.0 / scale; 4]);
                let t = self.g.intern(Node::D4(q));
                let local = std::array::from_fn(|i| self.g.intern(Node::Proj(t, i as u8)));
                let cell = std::array::from_fn(|i| self.g.intern(Node::Proj(t, 4 + i as u8)));
                (self.diag(local, [*scale; 4]), cell)
            }
            Lattice::Grid { spacing, limit } => {
                let q = self.diag(p, spacing.map(|s| 1.0 / s));
                let mut local = [q[0]; 4];
                let mut cell = [q[0]; 4];
                for i in 0..4 {
                    let t = self.g.intern(Node::Rep(q[i], K::new(limit[i])));
                    local[i] = self.g.intern(Node::Proj(t, 0));
                    cell[i] = self.g.intern(Node::Proj(t, 1));
                }
                (self.diag(local, *spacing), cell)
            }
        }
    }

    /// The distance to shape `s` at point `p`.
    fn shape(&mut self, s: &Shape, p: [Id; 4]) -> Id {
        use ShapeKind as S;
        // Shape parameters depend on `t` only; `p` and `n` are never read from them.
        let env = Env { p, n: p };
        let zero = self.k(0.0);
        match &s.kind {
            S::Hypersphere { radius } => {
                let len = self.g.intern(Node::Length(p, [K::new(0.0); 5]));
                let r = self.num(radius, env);
                self.bin(Bin::Sub, len, r)
            }
            S::Halfspace { normal, offset } => match (normal, offset.constant()) {
                (Param::Const(n), Some(o)) => {
                    let row = [n[0], n[1], n[2], n[3], -o].map(K::new);
                    self.g.intern(Node::Affine(p, row))
                }
                _ => {
                    let n = self.vector(normal, env);
                    let len = self.length(&Lv::V(n));
                    let d = self.zip(Bin::Mul, &Lv::V(p), &Lv::V(n)).lanes();
                    let d = self.sum(&d);
                    let d = self.bin(Bin::Div, d, len);
                    let o = self.num(offset, env);
                    self.bin(Bin::Sub, d, o)
                }
            },
            S::Hyperbox { half, radius } => {
                // `radius` rounds the edges inside the same extents: box(half - r) - r.
                let r = self.num(radius, env);
                match (half, radius.constant()) {
                    (Param::Const(h), Some(rc)) => {
                        let mut row = [K::new(0.0); 9];
                        for i in 0..4 {
                            row[4 + i] = K::new((h[i] - rc).max(0.0));
                        }
                        let d = self.g.intern(Node::BoxDist(p, row));
                        self.bin(Bin::Sub, d, r)
                    }
                    _ => {
                        let h = self.vector(half, env);
                        let ds: Vec<Id> = (0..4)
                            .map(|i| {
                                let a = self.un(Un::Abs, p[i]);
                                let hr = self.bin(Bin::Sub, h[i], r);
                                let hr = self.bin(Bin::Max, hr, zero);
                                self.bin(Bin::Sub, a, hr)
                            })
                            .collect();
                        let d = self.extrusion(&ds);
                        self.bin(Bin::Sub, d, r)
                    }
                }
            }
            S::Spherinder { radius, height } => {
                let r = self.num(radius, env);
                let h = self.num(height, env);
                let len = self.length(&Lv::V([p[0], p[1], p[2], zero]));
                let a = self.bin(Bin::Sub, len, r);
                let w = self.un(Un::Abs, p[3]);
                let b = self.bin(Bin::Sub, w, h);
                self.extrusion(&[a, b])
            }
            S::Cubinder { radius, height } => {
                let r = self.num(radius, env);
                let h = self.num(height, env);
                let len = self.length(&Lv::V([p[0], p[1], zero, zero]));
                let a = self.bin(Bin::Sub, len, r);
                let z = self.un(Un::Abs, p[2]);
                let b = self.bin(Bin::Sub, z, h);
                let w = self.un(Un::Abs, p[3]);
                let c = self.bin(Bin::Sub, w, h);
                self.extrusion(&[a, b, c])
            }
            S::Duocylinder { radius1, radius2 } => {
                let r1 = self.num(radius1, env);
                let r2 = self.num(radius2, env);
                let l1 = self.length(&Lv::V([p[0], p[1], zero, zero]));
                let l2 = self.length(&Lv::V([p[2], p[3], zero, zero]));
                let a = self.bin(Bin::Sub, l1, r1);
                let b = self.bin(Bin::Sub, l2, r2);
                self.extrusion(&[a, b])
            }
            S::Polytope { cells, radius } => {
                let r = self.num(radius, env);
                self.polytope(*cells, p, r)
            }
            S::Custom { distance } => self.num(distance, Env { p, n: p }),
            S::Union { shapes, smooth } | S::Intersect { shapes, smooth } => {
                let ds: Vec<Id> = shapes.iter().map(|c| self.shape(c, p)).collect();
                let k = self.num(smooth, env);
                let union = matches!(s.kind, S::Union { .. });
                ds.into_iter()
                    .reduce(|a, b| self.combine(union, a, b, k))
                    .expect("at least one shape")
            }
            S::Subtract { shape, cut, smooth } => {
                let a = self.shape(shape, p);
                let b = self.shape(cut, p);
                let nb = self.un(Un::Neg, b);
                let k = self.num(smooth, env);
                self.combine(false, a, nb, k)
            }
            S::Onion { shape, thickness } => {
                let d = self.shape(shape, p);
                let a = self.un(Un::Abs, d);
                let th = self.num(thickness, env);
                let half = self.k(0.5);
                let h = self.bin(Bin::Mul, th, half);
                self.bin(Bin::Sub, a, h)
            }
            S::Round { shape, radius } => {
                let d = self.shape(shape, p);
                let r = self.num(radius, env);
                self.bin(Bin::Sub, d, r)
            }
            S::Translate { shape, offset } => {
                let local = match offset {
                    Param::Const(o) => {
                        let id = [
                            [1.0, 0.0, 0.0, 0.0],
                            [0.0, 1.0, 0.0, 0.0],
                            [0.0, 0.0, 1.0, 0.0],
                            [0.0, 0.0, 0.0, 1.0],
                        ];
                        self.affine(p, id, o.map(|x| -x))
                    }
                    Param::Field(_) => {
                        let o = self.vector(offset, env);
                        std::array::from_fn(|i| self.bin(Bin::Sub, p[i], o[i]))
                    }
                };
                self.shape(shape, local)
            }
            S::Rotate { shape, rotation } => {
                // The shape turned by r1 then r2 is seen at R1^-1 R2^-1 p: undo the last first.
                let mut q = p;
                for (plane, angle) in rotation.iter().rev() {
                    q = match angle {
                        Param::Const(a) => {
                            let m = rotation_matrix(*plane, -a);
                            self.affine(q, m, [0.0; 4])
                        }
                        Param::Field(_) => {
                            let a = self.num(angle, env);
                            let (c, sn) = (self.un(Un::Cos, a), self.un(Un::Sin, a));
                            let (i, j) = plane.axes();
                            let mut out = q;
                            let (ci, sj) =
                                (self.bin(Bin::Mul, c, q[i]), self.bin(Bin::Mul, sn, q[j]));
                            out[i] = self.bin(Bin::Add, ci, sj);
                            let (cj, si) =
                                (self.bin(Bin::Mul, c, q[j]), self.bin(Bin::Mul, sn, q[i]));
                            out[j] = self.bin(Bin::Sub, cj, si);
                            out
                        }
                    };
                }
                self.shape(shape, q)
            }
            S::Scale { shape, factor } => {
                let k = self.num(factor, env);
                let local = match factor.constant() {
                    Some(f) => self.diag(p, [1.0 / f; 4]),
                    None => std::array::from_fn(|i| self.bin(Bin::Div, p[i], k)),
                };
                let d = self.shape(shape, local);
                self.bin(Bin::Mul, d, k)
            }
            S::Symmetry { shape, normal } => {
                // Reflect the half with dot(p, n) < 0 onto the other: p - 2 min(dot(p, n), 0) n.
                let n = self.vector(normal, env);
                let len = self.length(&Lv::V(n));
                let n: [Id; 4] = std::array::from_fn(|i| self.bin(Bin::Div, n[i], len));
                let d = self.zip(Bin::Mul, &Lv::V(p), &Lv::V(n)).lanes();
                let d = self.sum(&d);
                let d = self.bin(Bin::Min, d, zero);
                let two = self.k(2.0);
                let d2 = self.bin(Bin::Mul, d, two);
                let q = std::array::from_fn(|i| {
                    let m = self.bin(Bin::Mul, d2, n[i]);
                    self.bin(Bin::Sub, p[i], m)
                });
                self.shape(shape, q)
            }
            S::Tile { shape, lattice } => {
                let (local, _) = self.cell(lattice, p);
                self.shape(shape, local)
            }
        }
    }

    /// min / max, smooth when `k` may be positive.
    fn combine(&mut self, union: bool, a: Id, b: Id, k: Id) -> Id {
        match (self.g.constant(k), union) {
            (Some(k), true) if k <= 0.0 => self.bin(Bin::Min, a, b),
            (Some(k), false) if k <= 0.0 => self.bin(Bin::Max, a, b),
            (_, true) => self.g.intern(Node::SMin(a, b, k)),
            (_, false) => self.g.intern(Node::SMax(a, b, k)),
        }
    }

    /// The exact distance to a product of shapes given each factor's distance:
    /// |max(d, 0)| + min(max_i d_i, 0).
    fn extrusion(&mut self, ds: &[Id]) -> Id {
        let zero = self.k(0.0);
        let mut pos = [zero; 4];
        for (i, d) in ds.iter().enumerate() {
            pos[i] = self.bin(Bin::Max, *d, zero);
        }
        let out = self.g.intern(Node::Length(pos, [K::new(0.0); 5]));
        let m = ds[1..].iter().fold(ds[0], |m, d| self.bin(Bin::Max, m, *d));
        let inside = self.bin(Bin::Min, m, zero);
        self.bin(Bin::Add, out, inside)
    }

    /// Regular polytopes of circumradius `r` as the largest signed distance to their facet
    /// hyperplanes: a distance bound, exact on the facets.
    fn polytope(&mut self, cells: Polytope, p: [Id; 4], r: Id) -> Id {
        let a = p.map(|x| self.un(Un::Abs, x));
        match cells {
            Polytope::Cell16 => {
                // Facets x . (+-1/2, ...) = r/2.
                let row = [0.5, 0.5, 0.5, 0.5, 0.0].map(K::new);
                let d = self.g.intern(Node::Affine(a, row));
                let half = self.k(0.5);
                let h = self.bin(Bin::Mul, r, half);
                self.bin(Bin::Sub, d, h)
            }
            Polytope::Cell24 => {
                // Facet normals: the 8 axes and the 16 (+-1/2, ...); inradius r / sqrt(2).
                let row = [0.5, 0.5, 0.5, 0.5, 0.0].map(K::new);
                let s = self.g.intern(Node::Affine(a, row));
                let m01 = self.bin(Bin::Max, a[0], a[1]);
                let m23 = self.bin(Bin::Max, a[2], a[3]);
                let m = self.bin(Bin::Max, m01, m23);
                let d = self.bin(Bin::Max, m, s);
                let f = self.k(std::f64::consts::FRAC_1_SQRT_2);
                let ir = self.bin(Bin::Mul, r, f);
                self.bin(Bin::Sub, d, ir)
            }
            Polytope::Cell5 => {
                // The 5-cell: facet normals point away from the five vertices; inradius r / 4.
                let ds: Vec<Id> = simplex_vertices()
                    .iter()
                    .map(|v| {
                        let row = [-v[0], -v[1], -v[2], -v[3], 0.0].map(K::new);
                        self.g.intern(Node::Affine(p, row))
                    })
                    .collect();
                let d = ds[1..].iter().fold(ds[0], |m, d| self.bin(Bin::Max, m, *d));
                let q = self.k(0.25);
                let ir = self.bin(Bin::Mul, r, q);
                self.bin(Bin::Sub, d, ir)
            }
        }
    }
}

/// Unit vertices of a regular 4-simplex centred on the origin.
pub fn simplex_vertices() -> [[f64; 4]; 5] {
    // e_i - centroid in R^5, expressed in an orthonormal basis of the hyperplane sum = 0.
    let s5 = 5f64.sqrt();
    let raw = [
        [1.0, 1.0, 1.0, -1.0 / s5],
        [1.0, -1.0, -1.0, -1.0 / s5],
        [-1.0, 1.0, -1.0, -1.0 / s5],
        [-1.0, -1.0, 1.0, -1.0 / s5],
        [0.0, 0.0, 0.0, 4.0 / s5],
    ];
    raw.map(|v| {
        let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        v.map(|x| x / n)
    })
}
