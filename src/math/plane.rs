//! The six coordinate planes of 4D and rotations in them.

/// A coordinate plane, as an axis pair (x=0, y=1, z=2, w=3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Plane {
    XY,
    XZ,
    XW,
    YZ,
    YW,
    ZW,
}

impl Plane {
    pub const ALL: [(&'static str, Plane); 6] = [
        ("xy", Plane::XY),
        ("xz", Plane::XZ),
        ("xw", Plane::XW),
        ("yz", Plane::YZ),
        ("yw", Plane::YW),
        ("zw", Plane::ZW),
    ];

    pub fn axes(self) -> (usize, usize) {
        match self {
            Plane::XY => (0, 1),
            Plane::XZ => (0, 2),
            Plane::XW => (0, 3),
            Plane::YZ => (1, 2),
            Plane::YW => (1, 3),
            Plane::ZW => (2, 3),
        }
    }

    pub fn name(self) -> &'static str {
        Plane::ALL
            .iter()
            .find(|(_, p)| *p == self)
            .map(|(n, _)| *n)
            .unwrap_or("?")
    }
}

/// The matrix turning by `angle` in `plane`, from its first axis towards its second.
pub fn rotation(plane: Plane, angle: f64) -> [[f64; 4]; 4] {
    let (i, j) = plane.axes();
    let mut m = [[0.0; 4]; 4];
    for (k, row) in m.iter_mut().enumerate() {
        row[k] = 1.0;
    }
    let (s, c) = angle.sin_cos();
    m[i][i] = c;
    m[i][j] = -s;
    m[j][i] = s;
    m[j][j] = c;
    m
}

/// `v` turned by each `(plane, angle)` in order, the first applied first.
pub fn rotate(v: [f64; 4], steps: impl IntoIterator<Item = (Plane, f64)>) -> [f64; 4] {
    steps.into_iter().fold(v, |v, (plane, angle)| {
        let m = rotation(plane, angle);
        std::array::from_fn(|r| (0..4).map(|c| m[r][c] * v[c]).sum::<f64>())
    })
}
