//! The types of the language, as the checker names them in messages and annotations.

use std::fmt;

#[derive(Clone, Debug, PartialEq)]
/// The type of a value in the scene language, as the checker infers and annotations name it.
pub enum Type {
    /// A double-precision number.
    Num,
    /// An angle (`15deg`, `0.5rad`), kept apart from plain numbers; stored in radians.
    Angle,
    /// `true` or `false`.
    Bool,
    /// A point or direction in 4D.
    Vec4,
    /// A linear RGB colour.
    Color,
    /// Text (`string` in annotations).
    Str,
    /// An image size, `w x h`.
    Size,
    /// One of the six coordinate planes, `xy` to `zw`.
    Plane,
    /// A composition of plane rotations.
    Rotation,
    /// A lattice for `tile`.
    Lattice,
    /// How a surface or volume interacts with light.
    Material,
    /// A solid in 4D.
    Shape,
    /// A list whose items all have the given type.
    List(Box<Type>),
    /// A function value, such as a material map `|p, n| ...`.
    Function,
    /// The element type of an empty list, or the type of an erroneous value: fits anything.
    Unknown,
}

impl Type {
    /// Numbers, angles, vectors and colours: the types arithmetic works on.
    pub fn is_numeric(&self) -> bool {
        matches!(self, Type::Num | Type::Angle | Type::Vec4 | Type::Color)
    }

    /// Whether a value of type `found` may be used where `self` is expected.
    pub fn accepts(&self, found: &Type) -> bool {
        match (self, found) {
            (Type::Unknown, _) | (_, Type::Unknown) => true,
            (Type::List(a), Type::List(b)) => a.accepts(b),
            (a, b) => a == b,
        }
    }

    /// Names accepted in annotations.
    pub fn from_name(name: &str) -> Option<Type> {
        Some(match name {
            "num" => Type::Num,
            "angle" => Type::Angle,
            "bool" => Type::Bool,
            "vec4" => Type::Vec4,
            "color" => Type::Color,
            "string" => Type::Str,
            "size" => Type::Size,
            "plane" => Type::Plane,
            "rotation" => Type::Rotation,
            "lattice" => Type::Lattice,
            "material" => Type::Material,
            "shape" => Type::Shape,
            "function" => Type::Function,
            _ => return None,
        })
    }

    /// Every type name annotations accept (`list` takes an item type), for suggestions.
    pub const NAMES: [&'static str; 14] = [
        "num", "angle", "bool", "vec4", "color", "string", "size", "plane", "rotation", "lattice",
        "material", "shape", "function", "list",
    ];
}

impl fmt::Display for Type {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            Type::Num => "num",
            Type::Angle => "angle",
            Type::Bool => "bool",
            Type::Vec4 => "vec4",
            Type::Color => "color",
            Type::Str => "string",
            Type::Size => "size",
            Type::Plane => "plane",
            Type::Rotation => "rotation",
            Type::Lattice => "lattice",
            Type::Material => "material",
            Type::Shape => "shape",
            Type::List(t) => return write!(f, "list[{t}]"),
            Type::Function => "function",
            Type::Unknown => "unknown",
        };
        f.write_str(s)
    }
}
