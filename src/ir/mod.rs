//! The SDF IR: a hash-consed graph of scalar operations (each unique node stored once, so common
//! subexpressions are shared by construction), lowered from the typed scene.
//!
//! Vectors are lowered to four scalar nodes; the few operations that produce several values at
//! once (the D4 decoder, lattice repetition, min-with-id) are tuple nodes read through `Proj`.

pub mod eval;
pub mod exact;
pub mod interval;
pub mod lower;
pub mod opt;
pub mod precise;
mod print;
pub mod prune;

pub use crate::math::{Bin, Un};
pub use lower::{MaterialIr, ObjectIr, SceneIr, lower};

use hashbrown::HashTable;
use rustc_hash::FxBuildHasher;
use std::hash::BuildHasher;

/// A node of the graph; children always have smaller ids than their parents.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Id(pub u32);

/// Inputs of a tape: the point, the surface normal (material maps only) and the frame variable.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Var {
    X,
    Y,
    Z,
    W,
    NX,
    NY,
    NZ,
    NW,
    T,
}

impl Var {
    pub const ALL: [Var; 9] = [
        Var::X,
        Var::Y,
        Var::Z,
        Var::W,
        Var::NX,
        Var::NY,
        Var::NZ,
        Var::NW,
        Var::T,
    ];
    pub const POINT: [Var; 4] = [Var::X, Var::Y, Var::Z, Var::W];
    pub const NORMAL: [Var; 4] = [Var::NX, Var::NY, Var::NZ, Var::NW];

    pub fn index(self) -> usize {
        self as usize
    }

    pub fn name(self) -> &'static str {
        ["x", "y", "z", "w", "nx", "ny", "nz", "nw", "t"][self as usize]
    }
}

/// A constant stored by its bits so nodes can be hashed; `-0.0` and `0.0` stay distinct, and
/// every NaN is one constant.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct K(u64);

impl K {
    pub fn new(x: f64) -> K {
        K(if x.is_nan() {
            f64::NAN.to_bits()
        } else {
            x.to_bits()
        })
    }
    pub fn get(self) -> f64 {
        f64::from_bits(self.0)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Node {
    Var(Var),
    Const(K),
    Un(Un, Id),
    Bin(Bin, Id, Id),
    /// `if c != 0 { a } else { b }`
    Select(Id, Id, Id),
    /// |v + offset| - sub, with `r` = offset (4), sub: a translated sphere in one operation.
    Length([Id; 4], [K; 5]),
    /// One row of an affine map: c . v + offset (`row` holds c0..c3, offset).
    Affine([Id; 4], [K; 5]),
    /// The hyperbox distance with constant half-extents, offset and rounding:
    /// |max(q, 0)| + min(max_i q_i, 0) - sub with q = |v + offset| - half;
    /// `r` = offset (4), half (4), sub.
    BoxDist([Id; 4], [K; 9]),
    /// Polynomial smooth minimum with blend width `k` (plain min when k <= 0).
    SMin(Id, Id, Id),
    /// Smooth maximum: -smin(-a, -b, k).
    SMax(Id, Id, Id),
    /// D4 nearest point of a point given in lattice units; a tuple of 8: the offset from the
    /// nearest lattice point (4), then the lattice point (4).
    D4([Id; 4]),
    /// Repetition along one axis in cell units with limit `l` (cells -l..=l); a tuple of 2:
    /// the offset from the cell centre, then the cell index.
    Rep(Id, K),
    /// Running minimum with the id of the nearest object; a tuple of 2 (distance, id):
    /// (d, id) when d < best, else (best, best_id).
    MinId(Id, Id, Id, K),
    /// Output `i` of a tuple node.
    Proj(Id, u8),
}

impl Node {
    /// The node's operands, in order.
    pub fn children(&self) -> Operands {
        let z = Id(0);
        let (ids, len) = match *self {
            Node::Var(_) | Node::Const(_) => ([z; 4], 0),
            Node::Un(_, a) | Node::Rep(a, _) | Node::Proj(a, _) => ([a, z, z, z], 1),
            Node::Bin(_, a, b) => ([a, b, z, z], 2),
            Node::Select(a, b, c) | Node::SMin(a, b, c) | Node::SMax(a, b, c) => ([a, b, c, z], 3),
            Node::MinId(a, b, c, _) => ([a, b, c, z], 3),
            Node::Length(v, _) | Node::Affine(v, _) | Node::BoxDist(v, _) | Node::D4(v) => (v, 4),
        };
        Operands { ids, len }
    }

    /// The same node with its operands renamed.
    pub fn map(&self, mut f: impl FnMut(Id) -> Id) -> Node {
        let mut v4 = |v: [Id; 4]| v.map(&mut f);
        match *self {
            n @ (Node::Var(_) | Node::Const(_)) => n,
            Node::Un(op, a) => Node::Un(op, f(a)),
            Node::Rep(a, l) => Node::Rep(f(a), l),
            Node::Proj(a, i) => Node::Proj(f(a), i),
            Node::Bin(op, a, b) => Node::Bin(op, f(a), f(b)),
            Node::Select(a, b, c) => Node::Select(f(a), f(b), f(c)),
            Node::SMin(a, b, c) => Node::SMin(f(a), f(b), f(c)),
            Node::SMax(a, b, c) => Node::SMax(f(a), f(b), f(c)),
            Node::MinId(a, b, c, k) => Node::MinId(f(a), f(b), f(c), k),
            Node::Length(v, r) => Node::Length(v4(v), r),
            Node::Affine(v, r) => Node::Affine(v4(v), r),
            Node::BoxDist(v, h) => Node::BoxDist(v4(v), h),
            Node::D4(v) => Node::D4(v4(v)),
        }
    }

    /// How many values the node produces (tuples are read through `Proj`).
    pub fn arity(&self) -> usize {
        match self {
            Node::D4(_) => 8,
            Node::Rep(..) | Node::MinId(..) => 2,
            _ => 1,
        }
    }
}

/// A node's operands, without allocating (graph passes visit every node).
#[derive(Clone, Copy, Debug)]
pub struct Operands {
    ids: [Id; 4],
    len: usize,
}

impl std::ops::Deref for Operands {
    type Target = [Id];
    fn deref(&self) -> &[Id] {
        &self.ids[..self.len]
    }
}

impl IntoIterator for Operands {
    type Item = Id;
    type IntoIter = std::iter::Take<std::array::IntoIter<Id, 4>>;
    fn into_iter(self) -> Self::IntoIter {
        self.ids.into_iter().take(self.len)
    }
}

/// The graph: nodes in an arena, interned so that each distinct node exists once.
#[derive(Clone, Debug, Default)]
pub struct Graph {
    nodes: Vec<Node>,
    /// The ids of the nodes, found by their hash and compared with the arena: a map keyed by
    /// the nodes held a copy of each (about 100 bytes; 4 here), and interning, a quarter of
    /// building a dense union's cells, was mostly moving them.
    index: HashTable<Id>,
}

fn hash(node: &Node) -> u64 {
    FxBuildHasher.hash_one(node)
}

impl Graph {
    pub fn new() -> Graph {
        Graph::default()
    }

    /// An empty graph with room for `n` nodes: interning grows its index by rehashing, which
    /// cost pruning half its time before its graphs were sized up front.
    pub fn with_capacity(n: usize) -> Graph {
        Graph {
            nodes: Vec::with_capacity(n),
            index: HashTable::with_capacity(n),
        }
    }

    /// The id of `node`, adding it if it is new.
    pub fn intern(&mut self, node: Node) -> Id {
        let node = match node {
            // Commutative operands in a canonical order, so `a + b` and `b + a` are one node.
            Node::Bin(op, a, b) if op.commutes() && b < a => Node::Bin(op, b, a),
            n => n,
        };
        let Graph { nodes, index } = self;
        let h = hash(&node);
        if let Some(&id) = index.find(h, |id| nodes[id.0 as usize] == node) {
            return id;
        }
        let id = Id(nodes.len() as u32);
        nodes.push(node);
        index.insert_unique(h, id, |id| hash(&nodes[id.0 as usize]));
        id
    }

    pub fn get(&self, id: Id) -> Node {
        self.nodes[id.0 as usize]
    }

    /// Every node, in id order (children before parents).
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    pub fn constant(&self, id: Id) -> Option<f64> {
        match self.get(id) {
            Node::Const(k) => Some(k.get()),
            _ => None,
        }
    }

    /// Copy the nodes `roots` need into a new graph, each through `add` (which receives it with
    /// its operands already renamed); returns the graph and the new id of every old one.
    pub fn rebuild(
        &self,
        roots: &[Id],
        mut add: impl FnMut(&mut Graph, Node) -> Id,
    ) -> (Graph, Vec<Id>) {
        let live = self.live(roots);
        let mut g = Graph::new();
        let mut map = vec![Id(u32::MAX); self.len()];
        for i in 0..self.len() {
            if live[i] {
                let n = self.get(Id(i as u32)).map(|c| map[c.0 as usize]);
                map[i] = add(&mut g, n);
            }
        }
        (g, map)
    }

    /// The nodes `roots` need, copied in order into a graph without an interning index
    /// (they are distinct already): a graph to read, prune and compile, built without
    /// hashing. Nodes interned into it later are not shared with these.
    pub fn compact(&self, roots: &[Id]) -> (Graph, Vec<Id>) {
        let live = self.live(roots);
        let mut g = Graph {
            nodes: Vec::with_capacity(live.iter().filter(|l| **l).count()),
            index: HashTable::new(),
        };
        let mut map = vec![Id(u32::MAX); self.len()];
        for i in (0..self.len()).filter(|i| live[*i]) {
            map[i] = Id(g.nodes.len() as u32);
            g.nodes.push(self.nodes[i].map(|c| map[c.0 as usize]));
        }
        (g, map)
    }

    /// Which nodes the given roots depend on, as a mask over ids.
    pub fn live(&self, roots: &[Id]) -> Vec<bool> {
        let mut live = vec![false; self.nodes.len()];
        for r in roots {
            live[r.0 as usize] = true;
        }
        for i in (0..self.nodes.len()).rev() {
            if live[i] {
                for c in self.nodes[i].children() {
                    live[c.0 as usize] = true;
                }
            }
        }
        live
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// Interning gives equal nodes one id and distinct nodes distinct ids, with `a + b` and
    /// `b + a` one node, across the index's growth (from no capacity) and in a clone: checked
    /// against a plain map on 20,000 random nodes drawn so that most repeat.
    #[test]
    fn interning_is_a_map_of_the_nodes() {
        let mut seed = 5u64;
        let mut rnd = |n: u64| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) % n
        };
        let mut g = Graph::new();
        let mut reference: HashMap<Node, Id> = HashMap::new();
        for v in Var::POINT {
            reference.insert(Node::Var(v), g.intern(Node::Var(v)));
        }
        for _ in 0..20_000 {
            let id = |r: u64| Id(r as u32);
            let n = g.len() as u64;
            let node = match rnd(4) {
                0 => Node::Const(K::new(rnd(50) as f64)),
                1 => {
                    let op = [Bin::Add, Bin::Sub, Bin::Mul, Bin::Min][rnd(4) as usize];
                    Node::Bin(op, id(rnd(n.min(40))), id(rnd(n.min(40))))
                }
                2 => Node::Un(Un::Abs, id(rnd(n.min(60)))),
                _ => Node::BoxDist(
                    [id(rnd(4)), id(rnd(4)), id(rnd(4)), id(rnd(4))],
                    [K::new(rnd(3) as f64); 9],
                ),
            };
            let canonical = match node {
                Node::Bin(op, a, b) if op.commutes() && b < a => Node::Bin(op, b, a),
                n => n,
            };
            let got = g.intern(node);
            let want = *reference.entry(canonical).or_insert(got);
            assert_eq!(got, want, "{node:?}");
        }
        assert_eq!(g.len(), reference.len());
        let mut copy = g.clone();
        for (i, node) in g.nodes().iter().enumerate() {
            assert_eq!(copy.intern(*node), Id(i as u32));
        }
        assert_eq!(copy.len(), g.len());
    }
}
