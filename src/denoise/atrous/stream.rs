//! The filter as a stream: frames go in one at a time, in order, and come out filtered as soon
//! as every frame they depend on has gone in, so only a window of frames is held whatever the
//! length of the animation.
//!
//! Pass `p` of frame `k` reads the colours entering pass `p` of frames `k - r ..= k + r`, where
//! the reach `r` is 0 for a spatial pass, 1 for a temporal one, and 2 for a temporal one in
//! flux form (whose update of `k` takes the weight sums of `k`'s neighbours, and those sum over
//! their own neighbours). So the passes run as a wavefront: each pass computes its next frame
//! once the pass before has delivered the frames it reaches, and drops what no later frame will
//! read. Every row is computed by the same code on the same inputs as when the whole animation
//! is held, so the result is the same bit for bit.

use super::guides::{self, CHANNELS, COLOR_PLANES, Guides, Scales, split, to_planes};
use super::kernel::{Pass, Term};
use super::{AtrousOptions, FRAME_WEIGHTS, remodulated};
use crate::film::Film;
use glam::DVec3;
use rayon::prelude::*;

/// The colours entering one pass (or, after the last, leaving the filter), per frame: empty
/// when not (or no longer) held, or for a film without guides.
#[derive(Default)]
struct Colours {
    cur: Vec<Vec<f64>>,
    /// The same as scaled `f32` pairs (not kept after the last pass).
    cur32: Vec<Vec<f32>>,
    /// Frames delivered so far.
    ready: usize,
}

/// What a pass keeps between frames: weight sums and the tap weights they left.
#[derive(Default)]
struct PassState {
    sums: Vec<Vec<f64>>,
    stored: Vec<Vec<f32>>,
    summed: Vec<bool>,
    /// The next frame this pass computes.
    next: usize,
}

/// The a-trous filter over a stream of `frames` frames.
pub struct Stream {
    opts: AtrousOptions,
    frames: usize,
    scales: Scales,
    films: Vec<Option<Film>>,
    guides: Vec<Option<Guides>>,
    /// Each arrived frame's size, `None` for a film whose buffers disagree with it.
    sizes: Vec<Option<(usize, usize)>>,
    colours: Vec<Colours>,
    passes: Vec<PassState>,
    /// The next frame to hand out.
    out: usize,
}

/// A frame out of the filter: the film, its colour filtered, and whether it was (a film whose
/// buffers disagree with its size is handed back as it came).
pub struct Filtered {
    pub film: Film,
    pub filtered: bool,
}

impl Stream {
    /// A stream of `frames` frames whose guides are stored at `scales` (the scales of all of
    /// them, see [`Scales`]).
    pub fn new(frames: usize, opts: &AtrousOptions, scales: Scales) -> Stream {
        let passes = opts.pass_range().len();
        fn per_frame<T: Default>(frames: usize) -> Vec<T> {
            (0..frames).map(|_| T::default()).collect()
        }
        Stream {
            opts: opts.clone(),
            frames,
            scales,
            films: (0..frames).map(|_| None).collect(),
            guides: (0..frames).map(|_| None).collect(),
            sizes: vec![None; frames],
            colours: (0..=passes)
                .map(|_| Colours {
                    cur: per_frame(frames),
                    cur32: per_frame(frames),
                    ready: 0,
                })
                .collect(),
            passes: (0..passes)
                .map(|_| PassState {
                    sums: per_frame(frames),
                    stored: per_frame(frames),
                    summed: vec![false; frames],
                    next: 0,
                })
                .collect(),
            out: 0,
        }
    }

    /// Take the next frame; returns the frames that are now finished, in order.
    ///
    /// # Panics
    /// If more frames are pushed than the stream was made for.
    pub fn push(&mut self, film: Film) -> Vec<Filtered> {
        let k = self.colours[0].ready;
        assert!(k < self.frames, "more frames than the stream was made for");
        self.guides[k] = guides::of_frame(&film, &self.opts, self.scales);
        self.sizes[k] = self.guides[k].as_ref().map(|_| (film.width, film.height));
        let cur = match &self.guides[k] {
            Some(g) => to_planes((g.w, g.h, g.s), |p| {
                (film.color[p] / g.albedo[p]).to_array()
            }),
            None => Vec::new(),
        };
        self.films[k] = Some(film);
        self.deliver(0, k, cur);
        while self.step() {}
        self.finished()
    }

    /// The reach of pass `p` (see the module notes).
    fn reach(&self, p: usize) -> usize {
        match (self.opts.temporal.reaches(p as u32), self.opts.conserve) {
            (false, _) => 0,
            (true, false) => 1,
            (true, true) => 2,
        }
    }

    /// Frame `k`'s colours entering pass `p` (or leaving the filter when `p` is the last).
    fn deliver(&mut self, p: usize, k: usize, cur: Vec<f64>) {
        let last = p == self.passes.len();
        let c = &mut self.colours[p];
        if !last && let Some(g) = &self.guides[k] {
            let scale_c = self.scales.factors().1;
            let mut cur32 = vec![0.0; COLOR_PLANES * g.s * g.h];
            let s = g.s;
            cur32
                .par_chunks_mut(COLOR_PLANES * s)
                .zip(cur.par_chunks(CHANNELS * s))
                .for_each(|(row, src)| {
                    for c in 0..CHANNELS {
                        for x in 0..s {
                            (row[c * s + x], row[(CHANNELS + c) * s + x]) =
                                split(src[c * s + x] * scale_c);
                        }
                    }
                });
            c.cur32[k] = cur32;
        }
        c.cur[k] = cur;
        c.ready = k + 1;
    }

    /// Whether frames `k` and `kq` may exchange taps.
    fn neighbours(&self, k: usize, kq: usize) -> bool {
        kq < self.frames && self.sizes[k].is_some() && self.sizes[k] == self.sizes[kq]
    }

    /// Run the first pass that can compute its next frame; false when none can.
    fn step(&mut self) -> bool {
        for p in 0..self.passes.len() {
            let k = self.passes[p].next;
            let needs = (k + self.reach(p) + 1).min(self.frames);
            if k < self.frames && self.colours[p].ready >= needs {
                self.run(p, k);
                return true;
            }
        }
        false
    }

    /// Pass `p` of frame `k`.
    fn run(&mut self, p: usize, k: usize) {
        let temporal = self.opts.temporal.reaches(p as u32);
        let sources_of = |j: usize| {
            let mut s = Vec::with_capacity(3);
            if temporal && j > 0 && self.neighbours(j, j - 1) {
                s.push((j - 1, FRAME_WEIGHTS[0]));
            }
            s.push((j, FRAME_WEIGHTS[1]));
            if temporal && self.neighbours(j, j + 1) {
                s.push((j + 1, FRAME_WEIGHTS[2]));
            }
            s
        };
        // Only the frames whose taps this frame's update reads need their sources.
        let mut sources = vec![Vec::new(); self.frames];
        let near = k.saturating_sub(1)..(k + 2).min(self.frames);
        for (s, j) in sources[near.clone()].iter_mut().zip(near) {
            *s = sources_of(j);
        }
        let opts = &self.opts;
        let sc = opts.sigma_color_at(p as u32);
        let colours = &self.colours[p];
        let step = Pass {
            guides: &self.guides,
            cur: &colours.cur,
            cur32: &colours.cur32,
            sources,
            temporal,
            step: 1 << p,
            sc2: (sc * sc) as f32,
            sx2: (opts.sigma_position * opts.sigma_position) as f32,
            albedo: Term::new(opts.sigma_albedo * opts.sigma_albedo),
            normal: Term::new(opts.sigma_normal * opts.sigma_normal),
        };
        let mut out = Vec::new();
        if let Some(g) = &self.guides[k]
            && g.w > 0
        {
            out = vec![0.0; CHANNELS * g.s * g.h];
            let state = &mut self.passes[p];
            if opts.conserve {
                // The weight sums of every frame the update reads, each once.
                for &(j, _) in &step.sources[k] {
                    if state.summed[j] {
                        continue;
                    }
                    if let Some(g) = &self.guides[j]
                        && g.w > 0
                    {
                        let mut sums = vec![0.0; g.s * g.h];
                        let mut stored = vec![0.0; g.h * step.taps() * g.w];
                        sums.par_chunks_mut(g.s)
                            .zip(stored.par_chunks_mut(step.taps() * g.w))
                            .enumerate()
                            .for_each(|(y, (row, st))| step.sums_row((j, y), row, st));
                        state.sums[j] = sums;
                        state.stored[j] = stored;
                    }
                    state.summed[j] = true;
                }
                let (sums, stored) = (&state.sums[..], &state.stored[k]);
                out.par_chunks_mut(CHANNELS * g.s)
                    .zip(stored.par_chunks(step.taps() * g.w))
                    .enumerate()
                    .for_each(|(y, (row, st))| step.update_row((k, y), Some((sums, st)), row));
            } else {
                out.par_chunks_mut(CHANNELS * g.s)
                    .enumerate()
                    .for_each(|(y, row)| step.update_row((k, y), None, row));
            }
        }
        // What no later frame of this pass reads.
        let reach = self.reach(p);
        let state = &mut self.passes[p];
        state.next = k + 1;
        state.stored[k] = Vec::new();
        if let Some(j) = k.checked_sub(1) {
            state.sums[j] = Vec::new();
        }
        if let Some(j) = k.checked_sub(reach) {
            self.colours[p].cur[j] = Vec::new();
            self.colours[p].cur32[j] = Vec::new();
        }
        self.deliver(p + 1, k, out);
    }

    /// Hand out the frames every pass is done with, and drop the guides no pass reads again.
    fn finished(&mut self) -> Vec<Filtered> {
        let last = self.passes.len();
        let mut done = vec![];
        while self.out < self.colours[last].ready {
            let k = self.out;
            let mut film = self.films[k].take().expect("a frame is handed out once");
            let cur = std::mem::take(&mut self.colours[last].cur[k]);
            let filtered = match &self.guides[k] {
                Some(g) => {
                    film.color = remodulated(&film, &g.albedo, |p| {
                        let (x, y) = (p % g.w, p / g.w);
                        let row = &cur[y * CHANNELS * g.s..];
                        DVec3::new(row[x], row[g.s + x], row[2 * g.s + x])
                    });
                    true
                }
                None => false,
            };
            done.push(Filtered { film, filtered });
            self.out += 1;
        }
        // A pass about to compute frame `k` reads guides from `k - reach` on.
        let keep = (0..self.passes.len())
            .map(|p| self.passes[p].next.saturating_sub(self.reach(p)))
            .min()
            .unwrap_or(self.out)
            .min(self.out);
        for g in &mut self.guides[..keep] {
            *g = None;
        }
        done
    }
}
