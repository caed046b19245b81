//! The mode a written file ends up with. Files are written through temporary files, which are
//! created 0600; a plain `File::create` would give `0o666` less the umask, and overwriting a file
//! keeps its mode, so that is what the renamed file gets.

use std::fs::{self, Permissions};
use std::os::unix::fs::PermissionsExt;
use std::path::Path;
use std::sync::OnceLock;

/// The permissions `target` should have once written: those of the file it replaces, else those
/// of a new file.
pub(super) fn for_target(target: &Path) -> Permissions {
    match fs::metadata(target) {
        Ok(m) => m.permissions(),
        Err(_) => Permissions::from_mode(new_file_mode(umask())),
    }
}

/// The mode `open(2)` gives a new file created with mode 0666.
pub(super) fn new_file_mode(umask: u32) -> u32 {
    0o666 & !umask
}

/// The process's umask, read afresh where the system reports it, so a change made later in the
/// process is seen.
pub(super) fn umask() -> u32 {
    #[cfg(any(target_os = "linux", target_os = "android"))]
    if let Some(m) = fs::read_to_string("/proc/self/status")
        .ok()
        .as_deref()
        .and_then(parse_status_umask)
    {
        return m;
    }
    // umask(2) can only be read by setting it, which changes it for every thread until it is
    // restored, so this is done once. The mask set meanwhile is the strictest, so a file another
    // thread creates in that moment is too private rather than too open.
    static SET_AND_RESTORED: OnceLock<u32> = OnceLock::new();
    // `mode_t` is u16 on some systems.
    #[allow(clippy::useless_conversion)]
    *SET_AND_RESTORED.get_or_init(|| {
        // SAFETY: umask(2) cannot fail and touches no memory.
        let old = unsafe { libc::umask(0o077) };
        unsafe { libc::umask(old) };
        old.into()
    })
}

/// The `Umask:` line of `/proc/self/status` (Linux 4.7 and later), in octal.
#[cfg(any(target_os = "linux", target_os = "android"))]
pub(super) fn parse_status_umask(status: &str) -> Option<u32> {
    status
        .lines()
        .find_map(|line| line.strip_prefix("Umask:"))
        .and_then(|v| u32::from_str_radix(v.trim(), 8).ok())
}
