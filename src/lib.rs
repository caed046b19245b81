//! hyperslice renders four-dimensional scenes written in the `.4ds` language: it path-traces the
//! 3D hyperplane slice of a 4D world that a camera sees, one slice per frame of an animation.
//!
//! # The pipeline
//!
//! Data flows one way; each stage owns one module and reads only what the stage before hands it:
//!
//! ```text
//! .4ds source --syntax--> AST --check--> typed scene (scene::Scene)
//!   --compile--> per-frame programs: SDF IR (ir), optimised, as bytecode tapes (vm)
//!   --render--> films (film) --denoise--> --output--> GIF / PNG / EXR
//! ```
//!
//! - [`Compilation`] loads a file (with its imports) or a string, parses it, checks it and
//!   holds every diagnostic and, without errors, the typed [`Scene`](scene::Scene): shapes,
//!   materials, lattices and settings as Rust types, with values that depend on the point, the
//!   normal or the frame variable `t` as field expressions.
//! - [`Compiled`] lowers the scene once; for each frame it folds `t` in, optimises and compiles
//!   the tapes the renderer runs, and places the lights. `hyperslice compile --emit ir|bytecode`
//!   prints exactly these. [`compile::Frames`] is the hand-off: `Send + Sync`, it builds each
//!   frame the renderer takes (tapes, cells, camera, material layouts, lights, media) and the
//!   render's settings; [`render::driver`] reads nothing else, through
//!   [`render::frame::FrameSource`].
//! - [`render()`] path-traces every frame on a thread pool (bit-identical whatever the number of
//!   threads), reporting progress and stopping when asked; [`write()`] encodes the frames.
//! - For long renders, [`farm`] splits the work into units (frames, or sample ranges of frames)
//!   that [`render::driver::render_units`] keeps in film files as they finish, so a render
//!   resumes where it stopped, runs as shards on several machines, and is finished (summed,
//!   denoised as a stream, encoded frame by frame) by [`farm::assemble`] in memory that does
//!   not grow with the number of frames. [`farm::job::Job`] runs all of it in one call (what
//!   `hyperslice render` runs), and [`farm::job::merge`] merges shards.
//!
//! Every fallible step returns [`Result`] with the one [`Error`] type. The stages' own modules
//! stay public for tests and benchmarks, but the items above are the API.
//!
//! # Example
//!
//! Compile a scene from a string, render one tiny frame and look at its pixels: a black ball
//! in front of the camera, under a white sky.
//!
//! ```
//! use hyperslice::{Compilation, Monitor, RenderOptions};
//!
//! let source = r#"
//!     render { size = 16 x 12  spp = 4  denoise = "none" }
//!     sky = rgb(1)
//!     object ball { shape = hypersphere(1) material = diffuse(albedo: 0) }
//! "#;
//! let scene = Compilation::from_source("ball.4ds", source).into_scene()?;
//! let progress = |_samples: u64| {};
//! let monitor = Monitor { progress: &progress, cancel: None };
//! let rendered = hyperslice::render(&scene, &RenderOptions::default(), monitor)?;
//!
//! let film = &rendered.frames[0];
//! let at = |x: usize, y: usize| film.color[y * film.width + x];
//! assert_eq!(at(0, 0).x, 1.0); // the corner sees the sky
//! assert!(at(8, 6).x < 0.01); // the centre sees the black ball
//! # Ok::<(), hyperslice::Error>(())
//! ```
//!
//! See `docs/language.md` for the language, `docs/physics.md` for what is computed, and
//! `docs/ir-and-vm.md` for the compiled forms and how to pin them in your own tests.

// Every public item outside the hidden plumbing modules is documented; with
// `cargo clippy -- -D warnings` a gap is an error.
#![warn(missing_docs)]

#[doc(hidden)]
pub mod check;
pub mod codes;
pub mod compile;
#[doc(hidden)]
pub mod denoise;
pub mod diagnostic;
pub mod error;
pub mod farm;
pub mod film;
#[doc(hidden)]
pub mod generate;
pub mod image;
#[doc(hidden)]
pub mod ir;
pub mod material;
#[doc(hidden)]
pub mod math;
#[doc(hidden)]
pub mod metrics;
pub mod output;
pub mod render;
pub mod scene;
#[doc(hidden)]
pub mod simd;
pub mod source;
#[doc(hidden)]
pub mod sweep;
#[doc(hidden)]
pub mod syntax;
#[doc(hidden)]
pub mod vm;

pub use compile::Compiled;
pub use error::{Error, Result};
pub use render::driver::{Monitor, Options as RenderOptions};

/// Frames rendered in memory by [`render()`].
pub struct Rendered {
    /// The frames, denoised with the scene's `denoise` filter.
    pub frames: Vec<film::Film>,
    /// Work counts summed over every frame: samples, distance evaluations, dropped samples.
    pub stats: render::integrator::Stats,
    /// Time spent denoising (part of `elapsed`).
    pub denoise_time: Duration,
    /// Wall-clock time of the whole call, rendering and denoising.
    pub elapsed: Duration,
}

/// Render every frame of `scene` in memory, telling `monitor` of progress and stopping when it
/// says so, then denoise them with the scene's filter.
///
/// Fails with [`Error::Cancelled`] when `monitor`'s cancel flag is set, or [`Error::Threads`]
/// when the worker threads cannot start.
///
/// ```
/// use hyperslice::{Compilation, Monitor, RenderOptions};
/// use std::sync::atomic::{AtomicU64, Ordering};
///
/// let source = r#"
///     render { size = 8 x 6  frames = 2  spp = 1  denoise = "none" }
///     sky = rgb(0.5, 0.7, 1)
///     object ball { shape = hypersphere(1) }
/// "#;
/// let scene = Compilation::from_source("ball.4ds", source).into_scene()?;
/// let taken = AtomicU64::new(0);
/// let progress = |n: u64| {
///     taken.fetch_add(n, Ordering::Relaxed);
/// };
/// let monitor = Monitor { progress: &progress, cancel: None };
/// let rendered = hyperslice::render(&scene, &RenderOptions::default(), monitor)?;
///
/// assert_eq!(rendered.frames.len(), 2);
/// let film = &rendered.frames[1];
/// assert_eq!((film.width, film.height), (8, 6));
/// assert!(film.color[0].z > 0.9); // the corner sees the blue sky
/// assert_eq!(rendered.stats.samples, 2 * 8 * 6);
/// assert_eq!(taken.load(Ordering::Relaxed), 2 * 8 * 6);
/// # Ok::<(), hyperslice::Error>(())
/// ```
pub fn render(scene: &scene::Scene, options: &RenderOptions, monitor: Monitor) -> Result<Rendered> {
    let start = Instant::now();
    let source = compile::Frames::new(scene);
    let (mut frames, stats) = render::driver::render_films(&source, options, monitor)?;
    let denoise_start = Instant::now();
    let threads = options.threads.or(source.shot.threads);
    farm::assemble::denoise_frames(&mut frames, scene.render.denoise, threads)?;
    Ok(Rendered {
        frames,
        stats,
        denoise_time: denoise_start.elapsed(),
        elapsed: start.elapsed(),
    })
}

/// Write rendered frames to `path` (`.gif`, `.png` or `.exr`, by its extension) with the
/// scene's exposure and frame rate; the file appears whole or not at all.
pub fn write(path: &Path, rendered: &Rendered, scene: &scene::Scene) -> Result<output::Written> {
    let images: Vec<_> = rendered.frames.iter().map(|f| f.image()).collect();
    let settings = output::OutputSettings {
        exposure: scene.render.exposure,
        fps: scene.render.fps,
    };
    Ok(output::write(path, &images, &settings)?)
}

use diagnostic::Diagnostic;
use source::SourceMap;
use std::path::Path;
use std::time::{Duration, Instant};

/// Which frame `--emit ir|bytecode` shows: tapes are specialised per frame, so the text is
/// exactly what that frame renders with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum At {
    /// Frame number (0 is the first).
    Frame(u32),
    /// An animation time `t` (0 on the first frame, 1 on the last).
    Time(f64),
}

impl std::default::Default for At {
    fn default() -> At {
        At::Frame(0)
    }
}

/// Everything one compilation produced: the loaded sources, the diagnostics of every stage,
/// the root file's syntax tree and, when there were no errors, the typed scene.
pub struct Compilation {
    /// Every file loaded: the root file (or in-memory text) and what it imports; diagnostics' spans
    /// point into it.
    pub sources: SourceMap,
    /// Errors and warnings of every stage, in the order the stages found them.
    pub diagnostics: Vec<Diagnostic>,
    /// The root file's syntax tree, kept even when checking failed (for `--emit ast`).
    #[doc(hidden)]
    pub ast: syntax::ast::Ast,
    /// The typed scene; `None` when parsing or checking failed.
    pub scene: Option<scene::Scene>,
    /// Every name use resolved to its definition, with its type: for editors.
    #[doc(hidden)]
    pub resolved: Vec<check::Resolved>,
}

impl From<check::Checked> for Compilation {
    fn from(c: check::Checked) -> Compilation {
        Compilation {
            sources: c.sources,
            diagnostics: c.diagnostics,
            ast: c.ast,
            scene: c.scene,
            resolved: c.resolved,
        }
    }
}

impl Compilation {
    /// Compile a file from disk; imports resolve relative to it.
    pub fn from_path(path: &Path) -> Compilation {
        Self::from_path_with(path, &[])
    }

    /// Compile a file with `-D NAME=VALUE` overrides of its top-level `let`s: each value is a
    /// constant expression, checked against the type of the value it replaces.
    pub fn from_path_with(path: &Path, defines: &[String]) -> Compilation {
        check::compile_path(path, defines).into()
    }

    /// Compile the unsaved text of the file at `path` (an editor's buffer); imports resolve
    /// relative to `path`.
    pub fn from_text(path: &Path, text: &str) -> Compilation {
        check::compile_text(path, text).into()
    }

    /// Compile text held in memory; imports resolve relative to the current directory.
    ///
    /// This never fails: a scene with mistakes comes back with its diagnostics and no typed
    /// scene.
    ///
    /// ```
    /// use hyperslice::Compilation;
    ///
    /// let source = "object ball { shape = hypersphere(radius: true) }";
    /// let compilation = Compilation::from_source("bad.4ds", source);
    /// assert!(compilation.has_errors());
    /// assert!(compilation.scene.is_none());
    /// let first = &compilation.diagnostics[0];
    /// assert_eq!(first.code, "E0201"); // wrong type: a bool where a number is needed
    /// let span = first.primary_span().unwrap();
    /// assert_eq!(&compilation.sources.get(span.file).text[span.range()], "true");
    /// assert!(compilation.render_diagnostics(false).contains("E0201"));
    ///
    /// let good = Compilation::from_source("good.4ds", &source.replace("true", "1"));
    /// assert!(!good.has_errors() && good.scene.is_some());
    /// ```
    pub fn from_source(name: &str, text: &str) -> Compilation {
        check::compile_source(name, text).into()
    }

    /// The typed scene, or [`Error::Compile`] with every diagnostic when it has errors.
    pub fn into_scene(self) -> Result<scene::Scene> {
        let name = (self.sources.files().next())
            .map_or_else(|| "the scene".to_string(), |(_, f)| f.name.clone());
        self.into_scene_named(name)
    }

    /// [`Compilation::into_scene`], the error naming the scene `name` (what generated it, say).
    pub fn into_scene_named(self, name: impl Into<String>) -> Result<scene::Scene> {
        match self.scene {
            Some(scene) if !self.has_errors() => Ok(scene),
            _ => Err(Error::Compile {
                scene: name.into(),
                diagnostics: self.diagnostics,
                sources: self.sources,
            }),
        }
    }

    /// Whether any diagnostic is an error (warnings alone leave the scene usable).
    pub fn has_errors(&self) -> bool {
        self.diagnostics.iter().any(Diagnostic::is_error)
    }

    /// Every diagnostic as the terminal shows it, with the source lines it points at; `color` adds
    /// ANSI colours.
    pub fn render_diagnostics(&self, color: bool) -> String {
        diagnostic::render_all(&self.diagnostics, &self.sources, color)
    }

    /// `--emit ast`
    pub fn emit_ast(&self) -> String {
        syntax::print::print_ast(&self.ast)
    }

    /// `--emit scene`: the typed, constant-evaluated scene, if it compiled.
    pub fn emit_scene(&self) -> Option<String> {
        self.scene.as_ref().map(|s| s.to_string())
    }

    /// `--emit ir`: the optimised SDF IR that frame `at` renders with.
    pub fn emit_ir(&self, at: At) -> Option<String> {
        self.program(at).map(|p| p.ir.to_string())
    }

    /// `--emit bytecode`: every tape that frame `at` renders with.
    pub fn emit_bytecode(&self, at: At) -> Option<String> {
        self.program(at).map(|p| p.to_string())
    }

    /// `--emit bytecode --cell X,Y,Z,W`: the cell that the cells' marcher (`--marcher cells`,
    /// and `auto` where its probe keeps the cells) runs at `point` in frame `at`: the deepest
    /// cell of the frame's tree holding it, or the region outside the tree's cube. Its header
    /// names the cell, then come its lower bounds, the pieces rays meet exactly and its scene
    /// and interior tapes (`vm::cells::Cell`'s `Display`). `None` if the scene did not
    /// compile or `point` is not finite.
    ///
    /// Cells are built lazily as rays reach them, but each is the same whatever built it
    /// first: this builds the frame's tree down to `point`, as a ray there would.
    pub fn emit_cell_bytecode(&self, at: At, point: [f64; 4]) -> Option<String> {
        use render::frame::Build;
        use render::march::MarcherKind;
        let scene = self.scene.as_ref()?;
        if !point.iter().all(|x| x.is_finite()) {
            return None;
        }
        let t = self.time(at)?;
        let fs = compile::Frames::new(scene).at(t, Build::marcher(MarcherKind::Cells));
        let cells = fs.cells.as_ref()?;
        Some(cells.find(glam::DVec4::from_array(point)).to_string())
    }

    /// The animation time of frame `at`, if the scene compiled.
    fn time(&self, at: At) -> Option<f64> {
        let scene = self.scene.as_ref()?;
        Some(match at {
            At::Frame(f) => compile::frame_time(f, scene.render.frames),
            At::Time(t) => t,
        })
    }

    /// The scene lowered once, if it compiled.
    pub fn compiled(&self) -> Option<compile::Compiled> {
        self.scene.as_ref().map(compile::Compiled::new)
    }

    /// The tapes of frame `at`, if the scene compiled.
    #[doc(hidden)]
    pub fn program(&self, at: At) -> Option<vm::Program> {
        let scene = self.scene.as_ref()?;
        let t = self.time(at)?;
        Some(compile::Compiled::new(scene).program(Some(t)))
    }
}
