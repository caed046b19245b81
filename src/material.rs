//! The shape of a material, shared by every stage: `Material<N, C>` is generic over how a
//! number and a colour are held, so the same type serves the checked scene (constants or
//! fields), the IR (node ids), the material tape's layout (output slots) and a hit point
//! (values). What the parameters mean to the language (their names, ranges and defaults) is
//! the builtin table's, in `scene`.

/// Which material a [`Material`] is, without its parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaterialKind {
    /// `diffuse`: a matte surface, optionally glowing.
    Diffuse,
    /// `light`: an emitter that reflects nothing.
    Light,
    /// `mirror`: a perfect mirror.
    Mirror,
    /// `glass`: a refracting surface with a medium inside.
    Glass,
    /// `shiny`: a GGX microfacet metal.
    Shiny,
    /// `fog`: a participating medium filling the object, with no surface.
    Fog,
    /// `air`: clear space, no surface and no medium (carves holes in a surrounding fog).
    Air,
}

impl MaterialKind {
    /// Every kind, in the builtin table's order.
    pub const ALL: [MaterialKind; 7] = [
        MaterialKind::Diffuse,
        MaterialKind::Light,
        MaterialKind::Mirror,
        MaterialKind::Glass,
        MaterialKind::Shiny,
        MaterialKind::Fog,
        MaterialKind::Air,
    ];

    /// The name in the language (`diffuse`, `glass`, ...).
    pub fn name(self) -> &'static str {
        match self {
            MaterialKind::Diffuse => "diffuse",
            MaterialKind::Light => "light",
            MaterialKind::Mirror => "mirror",
            MaterialKind::Glass => "glass",
            MaterialKind::Shiny => "shiny",
            MaterialKind::Fog => "fog",
            MaterialKind::Air => "air",
        }
    }

    /// Whether rays can travel inside an object of this material.
    pub fn has_interior(self) -> bool {
        matches!(
            self,
            MaterialKind::Glass | MaterialKind::Fog | MaterialKind::Air
        )
    }
}

/// One parameter: a number or a colour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Slot<N, C> {
    /// A number parameter.
    Num(N),
    /// A colour parameter.
    Color(C),
}

/// A material; parameters are in the order of the builtin table.
#[derive(Clone, Debug, PartialEq)]
pub enum Material<N, C> {
    /// A matte (Lambertian) surface.
    Diffuse {
        /// Reflectance per channel, 0 to 1 (default 0.8).
        albedo: C,
        /// Radiance emitted as well (default black).
        emission: C,
    },
    /// An emitter that reflects nothing.
    Light {
        /// Emitted colour (default white).
        color: C,
        /// Multiplies `color`: the emitted radiance is `color * intensity`.
        intensity: N,
    },
    /// A perfect mirror.
    Mirror {
        /// Reflectance per channel (default white).
        tint: C,
    },
    /// A refracting surface with a homogeneous medium inside.
    Glass {
        /// Index of refraction (default 1.5).
        ior: N,
        /// Transmittance per channel of each crossing (default white).
        tint: C,
        /// Extinction of the medium inside, per unit length (default 0: clear).
        extinction: N,
        /// Fraction of the extinction inside that scatters rather than absorbs, per channel.
        albedo: C,
    },
    /// A GGX microfacet metal.
    Shiny {
        /// Perceptual roughness, 0 (polished) to 1 (default 0.3).
        roughness: N,
        /// Reflectance at normal incidence per channel (default 0.9).
        color: C,
    },
    /// A participating medium filling the object (or all space, as the global `medium`).
    Fog {
        /// Extinction per unit length (default 0.1).
        extinction: N,
        /// Fraction of the extinction that scatters rather than absorbs, per channel.
        albedo: C,
        /// Henyey-Greenstein `g`: > 0 scatters forwards, < 0 backwards, 0 evenly.
        anisotropy: N,
    },
    /// Clear space: no surface and no medium.
    Air,
}

impl<N, C> Material<N, C> {
    /// Which material this is.
    pub fn kind(&self) -> MaterialKind {
        match self {
            Material::Diffuse { .. } => MaterialKind::Diffuse,
            Material::Light { .. } => MaterialKind::Light,
            Material::Mirror { .. } => MaterialKind::Mirror,
            Material::Glass { .. } => MaterialKind::Glass,
            Material::Shiny { .. } => MaterialKind::Shiny,
            Material::Fog { .. } => MaterialKind::Fog,
            Material::Air => MaterialKind::Air,
        }
    }

    /// The parameters, in the table's order.
    pub fn params(&self) -> Vec<Slot<&N, &C>> {
        use Slot::{Color as C, Num as N};
        match self {
            Material::Diffuse { albedo, emission } => vec![C(albedo), C(emission)],
            Material::Light { color, intensity } => vec![C(color), N(intensity)],
            Material::Mirror { tint } => vec![C(tint)],
            Material::Glass {
                ior,
                tint,
                extinction,
                albedo,
            } => vec![N(ior), C(tint), N(extinction), C(albedo)],
            Material::Shiny { roughness, color } => vec![N(roughness), C(color)],
            Material::Fog {
                extinction,
                albedo,
                anisotropy,
            } => vec![N(extinction), C(albedo), N(anisotropy)],
            Material::Air => vec![],
        }
    }

    /// A material of `kind` from its parameters in the table's order; `None` when they do not
    /// match the kind.
    pub fn from_params(kind: MaterialKind, params: Vec<Slot<N, C>>) -> Option<Material<N, C>> {
        use Slot::{Color as C, Num as N};
        let mut it = params.into_iter();
        let mut next = || it.next();
        let m = match kind {
            MaterialKind::Diffuse => match (next(), next()) {
                (Some(C(albedo)), Some(C(emission))) => Material::Diffuse { albedo, emission },
                _ => return None,
            },
            MaterialKind::Light => match (next(), next()) {
                (Some(C(color)), Some(N(intensity))) => Material::Light { color, intensity },
                _ => return None,
            },
            MaterialKind::Mirror => match next() {
                Some(C(tint)) => Material::Mirror { tint },
                _ => return None,
            },
            MaterialKind::Glass => match (next(), next(), next(), next()) {
                (Some(N(ior)), Some(C(tint)), Some(N(extinction)), Some(C(albedo))) => {
                    Material::Glass {
                        ior,
                        tint,
                        extinction,
                        albedo,
                    }
                }
                _ => return None,
            },
            MaterialKind::Shiny => match (next(), next()) {
                (Some(N(roughness)), Some(C(color))) => Material::Shiny { roughness, color },
                _ => return None,
            },
            MaterialKind::Fog => match (next(), next(), next()) {
                (Some(N(extinction)), Some(C(albedo)), Some(N(anisotropy))) => Material::Fog {
                    extinction,
                    albedo,
                    anisotropy,
                },
                _ => return None,
            },
            MaterialKind::Air => Material::Air,
        };
        Some(m)
    }

    /// The same material with every parameter converted by `f`, in the table's order. It
    /// allocates nothing, so it serves at every hit point.
    pub fn convert<N2, C2>(
        &self,
        mut f: impl FnMut(Slot<&N, &C>) -> Slot<N2, C2>,
    ) -> Material<N2, C2> {
        fn num<N, C>(s: Slot<N, C>) -> N {
            match s {
                Slot::Num(x) => x,
                Slot::Color(_) => unreachable!("a conversion keeps numbers and colours apart"),
            }
        }
        fn color<N, C>(s: Slot<N, C>) -> C {
            match s {
                Slot::Color(c) => c,
                Slot::Num(_) => unreachable!("a conversion keeps numbers and colours apart"),
            }
        }
        // Fields are evaluated in the order written, which is the table's.
        match self {
            Material::Diffuse { albedo, emission } => {
                let albedo = color(f(Slot::Color(albedo)));
                let emission = color(f(Slot::Color(emission)));
                Material::Diffuse { albedo, emission }
            }
            Material::Light {
                color: c,
                intensity,
            } => {
                let c = color(f(Slot::Color(c)));
                Material::Light {
                    color: c,
                    intensity: num(f(Slot::Num(intensity))),
                }
            }
            Material::Mirror { tint } => Material::Mirror {
                tint: color(f(Slot::Color(tint))),
            },
            Material::Glass {
                ior,
                tint,
                extinction,
                albedo,
            } => {
                let ior = num(f(Slot::Num(ior)));
                let tint = color(f(Slot::Color(tint)));
                let extinction = num(f(Slot::Num(extinction)));
                let albedo = color(f(Slot::Color(albedo)));
                Material::Glass {
                    ior,
                    tint,
                    extinction,
                    albedo,
                }
            }
            Material::Shiny {
                roughness,
                color: c,
            } => {
                let roughness = num(f(Slot::Num(roughness)));
                Material::Shiny {
                    roughness,
                    color: color(f(Slot::Color(c))),
                }
            }
            Material::Fog {
                extinction,
                albedo,
                anisotropy,
            } => {
                let extinction = num(f(Slot::Num(extinction)));
                let albedo = color(f(Slot::Color(albedo)));
                let anisotropy = num(f(Slot::Num(anisotropy)));
                Material::Fog {
                    extinction,
                    albedo,
                    anisotropy,
                }
            }
            Material::Air => Material::Air,
        }
    }
}
