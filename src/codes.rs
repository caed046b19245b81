//! Every diagnostic code with its long explanation, a scene that makes it and the fixed scene:
//! `hyperslice explain CODE` prints an entry, and a test keeps the table of codes in
//! `docs/language.md` (section 17) row for row equal to `meaning` and `example` here.

/// One diagnostic code.
pub struct Code {
    /// The code itself, `E` or `W` and four digits, e.g. `E0201`.
    pub code: &'static str,
    /// The short meaning, as the docs table gives it.
    pub meaning: &'static str,
    /// The docs table's example column (Markdown).
    pub example: &'static str,
    /// What the diagnostic means and why the language has it.
    pub explanation: &'static str,
    /// A scene with the mistake.
    pub wrong: &'static str,
    /// The same scene, fixed.
    pub fixed: &'static str,
    /// Whether `wrong` and `fixed` check on their own (imports need other files).
    pub standalone: bool,
}

macro_rules! code {
    ($code:literal, $meaning:literal, $example:literal, $explanation:literal,
     $wrong:literal, $fixed:literal $(, $standalone:literal)?) => {
        Code {
            code: $code,
            meaning: $meaning,
            example: $example,
            explanation: $explanation,
            wrong: $wrong,
            fixed: $fixed,
            standalone: true $(&& $standalone)?,
        }
    };
}

/// Every diagnostic code the language has, with its explanation and examples.
pub const CODES: &[Code] = &[
    code!(
        "E0001",
        "unexpected character",
        "`let r = 7 % 2` (the remainder operator is `mod`)",
        "A character that no token of the language starts with: an operator from another language \
         (`%`, `^`), a degree sign, or a letter outside ASCII in a name. The hint names what to \
         write instead.",
        "let r = 7 % 2\nobject ball { shape = hypersphere(r) }",
        "let r = 7 mod 2\nobject ball { shape = hypersphere(r) }"
    ),
    code!(
        "E0002",
        "unterminated string",
        "`import \"walls.4ds`",
        "A string runs to the end of its line without a closing `\"`. Strings never span lines.",
        "render { denoise = \"median }\nobject ball { shape = hypersphere(1) }",
        "render { denoise = \"median\" }\nobject ball { shape = hypersphere(1) }"
    ),
    code!(
        "E0003",
        "unterminated block comment",
        "`/* never closed`",
        "A `/*` comment has no `*/`, so it would swallow the rest of the file. Block comments do \
         not nest: the first `*/` closes one.",
        "/* a ball\nobject ball { shape = hypersphere(1) }",
        "/* a ball */\nobject ball { shape = hypersphere(1) }"
    ),
    code!(
        "E0004",
        "a number runs straight into a name",
        "`size = 512x384` (write `512 x 384`)",
        "Letters directly after a number. Only the angle units `deg`, `rad` and `turn` may follow \
         a number; an image size needs spaces around `x`.",
        "render { size = 512x384 }\nobject ball { shape = hypersphere(1) }",
        "render { size = 512 x 384 }\nobject ball { shape = hypersphere(1) }"
    ),
    code!(
        "E0010",
        "unexpected token: what was found, what was expected, and what was being parsed",
        "`render { spp: 16 }` (settings use `=`)",
        "The parser found a token where it cannot be. The report says what it found, what could \
         come there, and which construct it was reading; parsing then skips to the next item or \
         setting, so one run reports several mistakes.",
        "render { spp: 16 }\nobject ball { shape = hypersphere(1) }",
        "render { spp = 16 }\nobject ball { shape = hypersphere(1) }"
    ),
    code!(
        "E0011",
        "unclosed, mismatched or stray delimiter",
        "`let xs = [1, 2, 3`",
        "Brackets `()`, `[]` and `{}` must pair up. An opener never closed points at the opener; a \
         closer that closes nothing should be deleted; a closer of the wrong kind shows both ends.",
        "let xs = [1, 2, 3\nobject ball { shape = hypersphere(len(xs)) }",
        "let xs = [1, 2, 3]\nobject ball { shape = hypersphere(len(xs)) }"
    ),
    code!(
        "E0012",
        "nested too deeply (more than 256 levels)",
        "`let a = ((((...1...))))` with 300 parentheses",
        "Brackets, prefix operators, `else if` chains or expressions nest more than 256 levels. The \
         limit keeps every pass of the compiler within its stack; no real scene comes near it.",
        "let a = ((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((1))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))\nobject ball { shape = hypersphere(a) }",
        "let a = 1\nobject ball { shape = hypersphere(a) }"
    ),
    code!(
        "E0101",
        "unknown name, with a suggestion",
        "`shape = hypersfere(1)` (did you mean `hypersphere`?)",
        "A name that no `let`, `fn`, parameter, import or builtin defines. Near misses get a \
         suggestion, and so do names from other tools (`sphere`, `hypercube`, `metal`).",
        "object ball { shape = hypersfere(1) }",
        "object ball { shape = hypersphere(1) }"
    ),
    code!(
        "E0102",
        "duplicate definition (points at both)",
        "`let r = 1` and later `let r = 2`",
        "Two top-level definitions, two parameters of one function or two objects share a name. \
         Items may come in any order, so neither can hide the other.",
        "let r = 1\nlet r = 2\nobject ball { shape = hypersphere(r) }",
        "let r = 1\nlet r2 = 2\nobject ball { shape = hypersphere(r + r2) }"
    ),
    code!(
        "E0103",
        "unknown setting in a block, with a suggestion",
        "`render { spps = 16 }`",
        "A `render`, `camera` or `object` block has a fixed set of settings (section 13); this is \
         not one of them.",
        "render { spps = 16 }\nobject ball { shape = hypersphere(1) }",
        "render { spp = 16 }\nobject ball { shape = hypersphere(1) }"
    ),
    code!(
        "E0104",
        "duplicate setting or block",
        "`render { spp = 16, spp = 32 }`",
        "A setting is given twice in one block, or a scene has two `render`, `camera`, `sky` or \
         `medium` items. Which one should win would be a guess.",
        "render { spp = 16, spp = 32 }\nobject ball { shape = hypersphere(1) }",
        "render { spp = 32 }\nobject ball { shape = hypersphere(1) }"
    ),
    code!(
        "E0105",
        "missing required setting",
        "`object ball { material = mirror() }` (no `shape`)",
        "An object needs a `shape`; every other setting has a default.",
        "object ball { material = mirror() }",
        "object ball { shape = hypersphere(1), material = mirror() }"
    ),
    code!(
        "E0201",
        "wrong type: expected X, found Y",
        "`hypersphere(radius: true)`",
        "A value of one type where another is needed: an argument, a setting, an annotation, a \
         list item or an `if` condition. Four separate numbers where a `vec4` is wanted get the \
         bracketed form as the fix.",
        "object ball { shape = hypersphere(radius: true) }",
        "object ball { shape = hypersphere(radius: 1) }"
    ),
    code!(
        "E0202",
        "wrong number of arguments",
        "`sqrt(1, 2)`",
        "A call passes more positional arguments than the function takes, a positional argument \
         after a named one, `rgb` with two numbers, or a material map that does not take \
         `|p, n|`.",
        "let k = sqrt(1, 2)\nobject ball { shape = hypersphere(k) }",
        "let k = sqrt(2)\nobject ball { shape = hypersphere(k) }"
    ),
    code!(
        "E0203",
        "unknown named argument, with a suggestion",
        "`hypersphere(raduis: 1)`",
        "A named argument that the function has no parameter for.",
        "object ball { shape = hypersphere(raduis: 1) }",
        "object ball { shape = hypersphere(radius: 1) }"
    ),
    code!(
        "E0204",
        "missing argument",
        "`onion(hypersphere(1))` (no `thickness`)",
        "A parameter without a default was not given.",
        "object ball { shape = onion(hypersphere(1)) }",
        "object ball { shape = onion(hypersphere(1), thickness: 0.1) }"
    ),
    code!(
        "E0205",
        "argument given twice",
        "`hypersphere(1, radius: 2)`",
        "One parameter received a positional and a named argument, or two named ones.",
        "object ball { shape = hypersphere(1, radius: 2) }",
        "object ball { shape = hypersphere(radius: 2) }"
    ),
    code!(
        "E0206",
        "not callable",
        "`let r = 2` then `r(3)`",
        "Only functions can be called; this value is a number, a shape or another non-function.",
        "let r = 2\nobject ball { shape = hypersphere(r(3)) }",
        "let r = 2\nobject ball { shape = hypersphere(r * 3) }"
    ),
    code!(
        "E0207",
        "operator not defined for these types",
        "`hypersphere(1) + 1`",
        "An operator applied to types it does not combine (section 6.3). Shapes are combined with \
         `union`, `intersect` and `subtract`, not with arithmetic.",
        "object ball { shape = hypersphere(1) + 1 }",
        "object ball { shape = hypersphere(1 + 1) }"
    ),
    code!(
        "E0208",
        "a field (depends on `p`, `n` or `t`) where a compile-time constant is needed",
        "`render { frames = 10 + 10 * t }`",
        "Render settings, loop ranges, list sizes and a few parameters must be known before \
         rendering starts, but this value depends on the point `p`, the normal `n` or the frame \
         variable `t`, which are known only while rendering.",
        "render { frames = 10 + 10 * t }\nobject ball { shape = hypersphere(1) }",
        "render { frames = 20 }\nobject ball { shape = hypersphere(1) }"
    ),
    code!(
        "E0209",
        "index out of range or not a whole number",
        "`[1, 2, 3][3]`",
        "A constant index must be a whole number inside the list: `xs[0]` to `xs[len(xs) - 1]`.",
        "let r = [1, 2, 3][3]\nobject ball { shape = hypersphere(r) }",
        "let r = [1, 2, 3][2]\nobject ball { shape = hypersphere(r) }"
    ),
    code!(
        "E0210",
        "mixing angles and plain numbers",
        "`rotate(xw, 30deg + 0.5)` (write `0.5rad` or `30deg`)",
        "Angles have their own type so that degrees and radians cannot be confused. Give a number \
         a unit (`0.5rad`), or divide an angle by one (`a / 1deg`) to get a number.",
        "object box { shape = hyperbox(1) |> rotate(xw, 30deg + 0.5) }",
        "object box { shape = hyperbox(1) |> rotate(xw, 30deg + 0.5rad) }"
    ),
    code!(
        "E0301",
        "value out of range",
        "`hypersphere(radius: -1)`, `glass(ior: 0)`, `render { size = 0 x 240 }`, `1e400`, `exp(1000)`",
        "A value of the right type outside the range the parameter or setting allows. The label \
         gives the value and the rule. A number past the largest one (about 1.8e308), written \
         or computed, is one too; `inf` written as such is not.",
        "object ball { shape = hypersphere(radius: -1) }",
        "object ball { shape = hypersphere(radius: 1) }"
    ),
    code!(
        "E0302",
        "division by zero in a constant",
        "`let k = 1 / 0`",
        "A constant divided by zero (or `mod` zero), which has no value.",
        "let k = 1 / 0\nobject ball { shape = hypersphere(k) }",
        "let k = 1 / 2\nobject ball { shape = hypersphere(k) }"
    ),
    code!(
        "E0401",
        "recursion too deep (more than 64 calls)",
        "`fn f(n: num) -> num = if n == 0 { 0 } else { 1 + f(n - 1) }` called as `f(100)`",
        "Functions run at compile time and may nest 64 calls deep. A deeper recursion usually \
         misses its base case; use `if` so that only the taken branch runs.",
        "fn f(n: num) -> num = f(n - 1)\nobject ball { shape = hypersphere(f(3)) }",
        "fn f(n: num) -> num = if n <= 0 { 1 } else { f(n - 1) }\nobject ball { shape = hypersphere(f(3)) }"
    ),
    code!(
        "E0402",
        "expansion too large (a list or loop over 100000 items, or 1000000 nodes of work)",
        "`let xs = 0..1000000`",
        "Lists, ranges and loops are expanded at compile time, and so bounded: 100000 items, and \
         1000000 steps of evaluation for the file. To repeat a shape many times, `tile` it.",
        "let xs = 0..1000000\nobject ball { shape = hypersphere(len(xs)) }",
        "let xs = 0..10\nobject ball { shape = hypersphere(len(xs)) }"
    ),
    code!(
        "E0403",
        "cyclic definition",
        "`let a = a + 1`, or `let a = b` with `let b = a`",
        "A `let` that needs its own value, directly or through other `let`s. Use a `fn` for \
         recursion.",
        "let a = a + 1\nobject ball { shape = hypersphere(a) }",
        "let a = 1 + 1\nobject ball { shape = hypersphere(a) }"
    ),
    code!(
        "E0501",
        "import cycle",
        "`a.4ds` imports `b.4ds`, which imports `a.4ds`",
        "Files import each other in a loop. Move what both need into a third file that both import.",
        "// a.4ds\nimport \"b.4ds\"\n// b.4ds\nimport \"a.4ds\"",
        "// shared.4ds holds the definitions; a.4ds and b.4ds both\nimport \"shared.4ds\"",
        false
    ),
    code!(
        "E0502",
        "cannot read file",
        "`import \"missing.4ds\"`",
        "An imported file (or the scene itself) does not exist or cannot be read. Import paths are \
         relative to the importing file.",
        "import \"missing.4ds\"",
        "import \"lib/shapes.4ds\"",
        false
    ),
    code!(
        "E0503",
        "file is not UTF-8",
        "`import \"picture.png\"`",
        "A `.4ds` file is UTF-8 text; this one has bytes that are not.",
        "import \"picture.png\"",
        "import \"shapes.4ds\"",
        false
    ),
    code!(
        "E0504",
        "an imported file has scene items",
        "importing a file that contains an `object` or a `render` block",
        "An imported file is a library of `let`s and `fn`s; objects and scene blocks belong in \
         the file being rendered.",
        "// lib.4ds\nobject ball { shape = hypersphere(1) }",
        "// lib.4ds\nlet ball_shape = hypersphere(1)",
        false
    ),
    code!(
        "W0001",
        "unused binding (names starting with `_` are exempt)",
        "`let unused = 1`, never referred to",
        "A `let`, `fn`, parameter or loop variable that nothing uses: often a typo elsewhere. Start \
         its name with `_` to keep it.",
        "let unused = 1\nobject ball { shape = hypersphere(1) }",
        "let _unused = 1\nobject ball { shape = hypersphere(1) }"
    ),
    code!(
        "W0002",
        "tiled shape does not fit inside its lattice cell: the distance bound breaks and marching can overstep",
        "`hypersphere(1) \\|> tile(d4(scale: 1))` (the D4 cell leaves room for radius `sqrt(2)/2`)",
        "`tile` repeats a shape by folding space into one lattice cell; a shape that reaches past \
         the cell is cut off at the border and distances across it are wrong, so rays can step \
         through surfaces.",
        "object balls { shape = hypersphere(1) |> tile(d4(scale: 1)) }",
        "object balls { shape = hypersphere(0.5) |> tile(d4(scale: 1)) }"
    ),
    code!(
        "W0003",
        "unreachable object: its shape is provably empty",
        "`intersect(hypersphere(1), hypersphere(1) \\|> translate([5, 0, 0, 0]))`",
        "The object can never be seen: its shape is empty (an intersection of parts that do not \
         meet) or its material is `air`.",
        "object none { shape = intersect(hypersphere(1), hypersphere(1) |> translate([5, 0, 0, 0])) }",
        "object some { shape = intersect(hypersphere(1), hypersphere(1) |> translate([1, 0, 0, 0])) }"
    ),
    code!(
        "W0004",
        "the scene has no objects",
        "a file with only a `render` block",
        "Nothing to render: the picture would be the sky only.",
        "render { spp = 16 }",
        "render { spp = 16 }\nobject ball { shape = hypersphere(1) }"
    ),
    code!(
        "W0005",
        "nothing in the scene gives off light: the picture is black",
        "a scene with no `light(...)`, no `emission` and no `sky`",
        "Light in a render comes only from the sky, from `light(...)` materials and from a \
         `diffuse` material's `emission`. The sky is black unless a `sky = ...` item sets it, so a \
         scene with neither renders every pixel black. The warning is given only when that is \
         certain: a material map that may choose an emitting material does not trigger it. Add \
         a light, an emission, or a sky colour.",
        "object ball { shape = hypersphere(1) }",
        "sky = rgb(0.6, 0.7, 0.9)\nobject ball { shape = hypersphere(1) }"
    ),
];

/// The entry of `code` (any case).
pub fn find(code: &str) -> Option<&'static Code> {
    CODES.iter().find(|c| c.code.eq_ignore_ascii_case(code))
}

/// The long explanation as `hyperslice explain` prints it.
pub fn explain(c: &Code) -> String {
    let indent = |s: &str| s.lines().map(|l| format!("    {l}\n")).collect::<String>();
    format!(
        "{}: {}\n\n{}\n\nThis has the mistake:\n\n{}\nFixed:\n\n{}",
        c.code,
        c.meaning,
        textwrap(c.explanation),
        indent(c.wrong),
        indent(c.fixed)
    )
}

/// Wrap a paragraph at 80 columns.
fn textwrap(s: &str) -> String {
    let mut out = String::new();
    let mut line = 0;
    for word in s.split_whitespace() {
        if line > 0 && line + 1 + word.len() > 80 {
            out.push('\n');
            line = 0;
        } else if line > 0 {
            out.push(' ');
            line += 1;
        }
        out.push_str(word);
        line += word.len();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Section 17 of the language reference lists exactly these codes, meanings and examples.
    #[test]
    fn docs_table_is_this_table() {
        let docs = include_str!("../docs/language.md");
        let rows: Vec<&str> = docs
            .lines()
            .filter(|l| {
                l.len() > 8
                    && l.starts_with("| ")
                    && (l[2..].starts_with('E') || l[2..].starts_with('W'))
                    && l[3..7].chars().all(|c| c.is_ascii_digit())
            })
            .collect();
        let ours: Vec<String> = CODES
            .iter()
            .map(|c| format!("| {} | {} | {} |", c.code, c.meaning, c.example))
            .collect();
        assert_eq!(rows, ours);
    }

    /// Each wrong scene gives its code, and the fixed one does not.
    #[test]
    fn examples_give_their_code_and_fixes_do_not() {
        for c in CODES.iter().filter(|c| c.standalone) {
            let codes = |src: &str| -> Vec<&'static str> {
                crate::Compilation::from_source("example.4ds", src)
                    .diagnostics
                    .iter()
                    .map(|d| d.code)
                    .collect()
            };
            let wrong = codes(c.wrong);
            assert!(wrong.contains(&c.code), "{}: wrong gives {wrong:?}", c.code);
            // The examples are as short as they can be, so most have no light (W0005).
            let fixed: Vec<_> = (codes(c.fixed).into_iter())
                .filter(|f| *f != "W0005" || c.code == "W0005")
                .collect();
            assert!(fixed.is_empty(), "{}: fixed gives {fixed:?}", c.code);
        }
    }
}
