//! Files on disk: checking before a render that the output can be written, writing every file
//! atomically with the mode a file made in place would have, and the names of numbered frames.

#[cfg(unix)]
use super::permissions;
use super::{Format, OutputError};
use std::ffi::{OsStr, OsString};
use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use tempfile::{NamedTempFile, TempPath};

/// The directory `path` goes in (`""` for a bare file name, meaning the current directory).
pub(super) fn parent_dir(path: &Path) -> &Path {
    path.parent().unwrap_or(Path::new(""))
}

/// `dir` as something to open: the current directory when empty.
pub(super) fn dir_for_io(dir: &Path) -> &Path {
    if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    }
}

/// The directory exists, is a directory, and a file can be created there (the probe file is
/// removed again at once).
pub(super) fn check_directory(path: &Path) -> Result<(), OutputError> {
    let dir = parent_dir(path);
    match fs::metadata(dir_for_io(dir)) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => {
            return Err(OutputError::NotADirectory {
                path: path.to_path_buf(),
                dir: dir.to_path_buf(),
            });
        }
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            return Err(OutputError::MissingDirectory {
                path: path.to_path_buf(),
                dir: dir.to_path_buf(),
            });
        }
        Err(e) => {
            return Err(OutputError::DirectoryNotWritable {
                path: path.to_path_buf(),
                dir: dir.to_path_buf(),
                source: e,
            });
        }
    }
    NamedTempFile::new_in(dir_for_io(dir))
        .map(drop)
        .map_err(|source| OutputError::DirectoryNotWritable {
            path: path.to_path_buf(),
            dir: dir.to_path_buf(),
            source,
        })
}

/// Whether `a` and `b` name the same file. Existing paths are compared canonicalised; a path
/// that does not exist yet is compared by its canonical directory and file name.
fn same_file(a: &Path, b: &Path) -> bool {
    fn canonical(p: &Path) -> Option<PathBuf> {
        if let Ok(c) = fs::canonicalize(p) {
            return Some(c);
        }
        let dir = fs::canonicalize(dir_for_io(parent_dir(p))).ok()?;
        Some(dir.join(p.file_name()?))
    }
    match (canonical(a), canonical(b)) {
        (Some(a), Some(b)) => a == b,
        _ => a == b,
    }
}

/// Check before rendering that `path` can be written: it is not the scene file `input`, not a
/// directory, its extension is known, and its directory exists and is writable. Creates nothing
/// that remains.
pub fn check_writable(path: &Path, input: &Path) -> Result<Format, OutputError> {
    if same_file(path, input) {
        return Err(OutputError::IsInput {
            path: path.to_path_buf(),
        });
    }
    if path.is_dir() || path.file_name().is_none() {
        return Err(OutputError::IsDirectory {
            path: path.to_path_buf(),
        });
    }
    let format = Format::from_path(path)?;
    check_directory(path)?;
    Ok(format)
}

/// The file frame `index` of a numbered sequence goes to: `stem_0000.ext` beside `path`.
pub fn numbered_path(path: &Path, index: usize) -> PathBuf {
    let mut name = OsString::from(path.file_stem().unwrap_or_default());
    name.push(format!("_{index:04}"));
    if let Some(ext) = path.extension() {
        name.push(".");
        name.push(ext);
    }
    path.with_file_name(name)
}

/// Create a temporary file beside `path`, fill it with `fill`, and flush it to disk. The file
/// is deleted again if anything fails, or when the returned path is dropped unpersisted.
pub(super) fn write_temp(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<&mut fs::File>) -> Result<(), OutputError>,
) -> Result<TempPath, OutputError> {
    let io_err = io_error(path);
    let mut tmp = NamedTempFile::new_in(dir_for_io(parent_dir(path))).map_err(io_err)?;
    {
        let mut w = BufWriter::new(tmp.as_file_mut());
        fill(&mut w)?;
        w.flush().map_err(io_err)?;
    }
    tmp.as_file().sync_all().map_err(io_err)?;
    Ok(tmp.into_temp_path())
}

/// Move a finished temporary file to `target`, with the mode a file created or overwritten in
/// place would have.
pub(super) fn persist(tmp: TempPath, target: &Path) -> Result<(), OutputError> {
    #[cfg(unix)]
    fs::set_permissions(&tmp, permissions::for_target(target)).map_err(io_error(target))?;
    tmp.persist(target).map_err(|e| io_error(target)(e.error))
}

/// Write `bytes` to `path` atomically: into a temporary file beside it, flushed to disk, then
/// renamed over `path`.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let tmp = write_temp(path, |w| w.write_all(bytes).map_err(io_error(path)))?;
    persist(tmp, path)
}

/// [`write_atomic`] for a file made from the scene `input` (such as its compiled IR), refusing
/// to overwrite the scene itself.
pub fn write_derived(path: &Path, input: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    if same_file(path, input) {
        return Err(OutputError::IsInput {
            path: path.to_path_buf(),
        });
    }
    check_directory(path)?;
    write_atomic(path, bytes)
}

/// [`OutputError::Io`] on `path`.
pub(super) fn io_error(path: &Path) -> impl Fn(io::Error) -> OutputError + Copy + '_ {
    move |source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Numbered frames of `path` from an earlier run that `written` does not list: the files beside
/// `path` named `stem_NNNN.ext` (four or more digits; the extension in any case), spelt as
/// [`numbered_path`] spells them, sorted. Empty when the directory cannot be read.
pub fn stale_frames(path: &Path, written: &[PathBuf]) -> Vec<PathBuf> {
    let Some(stem) = path.file_stem() else {
        return Vec::new();
    };
    let Ok(entries) = fs::read_dir(dir_for_io(parent_dir(path))) else {
        return Vec::new();
    };
    let mut stale: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .map(|e| e.file_name())
        .filter(|name| is_numbered_name(name, stem, path.extension()))
        .map(|name| path.with_file_name(name))
        .filter(|p| p.is_file() && !written.contains(p))
        .collect();
    stale.sort();
    stale
}

/// Whether `name` is `stem_NNNN.ext` (or `stem_NNNN` without an extension), with four or more
/// digits and `ext` in any case.
pub(super) fn is_numbered_name(name: &OsStr, stem: &OsStr, ext: Option<&OsStr>) -> bool {
    let Some(rest) = name
        .as_encoded_bytes()
        .strip_prefix(stem.as_encoded_bytes())
        .and_then(|r| r.strip_prefix(b"_"))
    else {
        return false;
    };
    let digits = rest.iter().take_while(|b| b.is_ascii_digit()).count();
    let rest = &rest[digits..];
    digits >= 4
        && match ext {
            Some(ext) => rest
                .strip_prefix(b".")
                .is_some_and(|e| e.eq_ignore_ascii_case(ext.as_encoded_bytes())),
            None => rest.is_empty(),
        }
}
