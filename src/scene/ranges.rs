//! The range of every numeric render setting, one table for the scene's `render` block and the
//! command line's flags, so that `spp = 0` in a scene and `--spp 0` are refused alike and the
//! message gives the value and the range.

use super::print::Num;

/// The values one setting may take: a whole number in `[lo, hi]`, or (`whole` false) a number
/// in `(lo, hi]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SettingRange {
    /// The setting's name in the scene (`max_steps`).
    pub name: &'static str,
    /// The lower bound: included for whole numbers, excluded otherwise.
    pub lo: f64,
    /// The upper bound, included.
    pub hi: f64,
    /// Whether the value must be a whole number.
    pub whole: bool,
}

/// The range of a whole-number setting, `lo..=hi`.
pub const fn whole(name: &'static str, lo: f64, hi: f64) -> SettingRange {
    SettingRange {
        name,
        lo,
        hi,
        whole: true,
    }
}

/// The range of a setting in `(lo, hi]`.
pub const fn above(name: &'static str, lo: f64, hi: f64) -> SettingRange {
    SettingRange {
        name,
        lo,
        hi,
        whole: false,
    }
}

/// `frames`: 1 to 10000.
pub const FRAMES: SettingRange = whole("frames", 1.0, 10000.0);
/// `spp`: 1 to a million samples per pixel.
pub const SPP: SettingRange = whole("spp", 1.0, 1e6);
/// `bounces`: 0 to 1000.
pub const BOUNCES: SettingRange = whole("bounces", 0.0, 1000.0);
/// `max_steps`: 1 to a million marching steps.
pub const MAX_STEPS: SettingRange = whole("max_steps", 1.0, 1e6);
/// 2^53: every seed up to it is exact in a scene's numbers.
pub const SEED: SettingRange = whole("seed", 0.0, 9007199254740992.0);
/// `threads`: 0 (every core) to 1024.
pub const THREADS: SettingRange = whole("threads", 0.0, 1024.0);
/// `epsilon`: the marching hit distance, in `(0, 1]`.
pub const EPSILON: SettingRange = above("epsilon", 0.0, 1.0);
/// `fps`: in `(0, 100]`.
pub const FPS: SettingRange = above("fps", 0.0, 100.0);
/// `exposure`: in `(0, 1e6]`.
pub const EXPOSURE: SettingRange = above("exposure", 0.0, 1e6);
/// Each side of the image.
pub const SIDE: SettingRange = whole("each side of the image", 1.0, 16384.0);
/// One frame of an animation, by its 0-based number (`--frame`).
pub const FRAME: SettingRange = whole("frame", 0.0, FRAMES.hi - 1.0);

impl SettingRange {
    /// Whether `x` is a value the setting may take.
    pub fn contains(&self, x: f64) -> bool {
        if self.whole {
            x.fract() == 0.0 && x >= self.lo && x <= self.hi
        } else {
            x > self.lo && x <= self.hi
        }
    }

    /// What the values are: `a whole number from 1 to 1000000`, `a number in (0, 100]`.
    pub fn describe(&self) -> String {
        if self.whole {
            format!("a whole number from {} to {}", Num(self.lo), Num(self.hi))
        } else {
            format!("a number in ({}, {}]", Num(self.lo), Num(self.hi))
        }
    }

    /// A flag's value: the number, or a message with the value and the range.
    pub fn parse(&self, text: &str) -> Result<f64, String> {
        let range = format!("{} must be {}", self.name, self.describe());
        // A whole number is compared as written: `9007199254740993` would round to 2^53 as
        // a float and pass.
        if self.whole
            && let Ok(n) = text.trim().parse::<i128>()
            && (n < self.lo as i128 || n > self.hi as i128)
        {
            return Err(format!("`{text}` is out of range: {range}"));
        }
        match text.trim().parse::<f64>() {
            Ok(x) if x.is_finite() && self.contains(x) => Ok(x),
            Ok(x) if x.is_finite() => {
                let what = if self.whole && x.fract() != 0.0 {
                    "not a whole number"
                } else {
                    "out of range"
                };
                Err(format!("`{text}` is {what}: {range}"))
            }
            _ => Err(format!("`{text}` is not a number: {range}")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_give_the_value_and_the_range() {
        assert_eq!(SPP.parse("16"), Ok(16.0));
        assert_eq!(
            SPP.parse("-1").unwrap_err(),
            "`-1` is out of range: spp must be a whole number from 1 to 1000000"
        );
        assert_eq!(
            SPP.parse("1.5").unwrap_err(),
            "`1.5` is not a whole number: spp must be a whole number from 1 to 1000000"
        );
        assert_eq!(
            FPS.parse("1000").unwrap_err(),
            "`1000` is out of range: fps must be a number in (0, 100]"
        );
        assert_eq!(FPS.parse("100"), Ok(100.0));
        assert!(FPS.parse("0").is_err() && FPS.parse("nan").is_err());
        assert_eq!(
            SEED.parse("9007199254740993").unwrap_err(),
            "`9007199254740993` is out of range: seed must be a whole number from 0 to 9007199254740992"
        );
        assert_eq!(SEED.parse("9007199254740992"), Ok(9007199254740992.0));
        assert_eq!(
            FRAME.parse("-1").unwrap_err(),
            "`-1` is out of range: frame must be a whole number from 0 to 9999"
        );
    }
}
