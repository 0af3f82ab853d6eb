//! File output that never leaves a half-written file and never replaces what is not a file.
//!
//! - A new path or an existing **regular file** is written atomically: a temporary sibling is
//!   written, flushed to disk and renamed over the target, so a reader sees either the old file
//!   or the complete new one. An existing file keeps its permission bits.
//! - A **symbolic link** is followed to its final target and that target is written by the same
//!   rules; the link itself stays a link (renaming over the link's own path would replace the
//!   link with a regular file).
//! - Anything else that exists and is not a directory (a character or block device such as
//!   `/dev/null` or `/dev/stdout`, a FIFO, a socket) is **written in place**: opened for
//!   writing and written, never renamed over. Renaming over `/dev/null` as root would replace
//!   the system's null device with a regular file.
//! - A directory is refused with an error that names the path.

use crate::error::{CoreError, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Writes `bytes` to `path`: atomically over a regular file (or a new path), in place over a
/// device, FIFO or socket, through to the target of a symbolic link (the module doc gives the
/// rules).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let display = path.display().to_string();
    let target = resolve_links(path)?;
    match std::fs::metadata(&target) {
        Ok(meta) if meta.is_dir() => Err(CoreError::InvalidField {
            field: "path".into(),
            value: display,
            expected: "a file path, not a directory".into(),
        }),
        Ok(meta) if meta.is_file() => write_replacing(&target, bytes, Some(meta.permissions())),
        Ok(_) => write_in_place(&target, bytes),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => write_replacing(&target, bytes, None),
        Err(source) => Err(CoreError::Io {
            action: "inspect",
            path: display,
            source,
        }),
    }
}

/// Follows a chain of symbolic links to the path that is finally written. A dangling link
/// resolves to its (absent) target, which is then created.
fn resolve_links(path: &Path) -> Result<PathBuf> {
    let mut current = path.to_path_buf();
    // The kernel's own limit on link chains (ELOOP) is 40.
    for _ in 0..40 {
        match std::fs::symlink_metadata(&current) {
            Ok(meta) if meta.file_type().is_symlink() => {
                let link = std::fs::read_link(&current).map_err(|source| CoreError::Io {
                    action: "read link",
                    path: current.display().to_string(),
                    source,
                })?;
                current = if link.is_absolute() {
                    link
                } else {
                    current
                        .parent()
                        .map(|p| p.join(&link))
                        .unwrap_or_else(|| link.clone())
                };
            }
            _ => return Ok(current),
        }
    }
    Err(CoreError::InvalidField {
        field: "path".into(),
        value: path.display().to_string(),
        expected: "a path whose symbolic links end in a file (more than 40 links in a row)".into(),
    })
}

fn io_err(action: &'static str, p: &Path) -> impl FnOnce(std::io::Error) -> CoreError {
    let path = p.display().to_string();
    move |source| CoreError::Io {
        action,
        path,
        source,
    }
}

/// The operating-system error of a failed temporary-file creation without the temporary
/// file's name that `tempfile` appends ("… at path \"/dir/.x.html.L4wDJd.tmp\""): the message
/// names the directory, and the random name means nothing to the user.
fn without_temp_path(e: std::io::Error) -> std::io::Error {
    if e.get_ref().is_none() {
        return e;
    }
    let text = e.to_string();
    match text.split_once(" at path \"") {
        Some((head, _)) => std::io::Error::new(e.kind(), head.to_string()),
        None => e,
    }
}

/// Temporary sibling, fsync, rename over `path`; the temporary file is removed on any error.
fn write_replacing(
    path: &Path,
    bytes: &[u8],
    permissions: Option<std::fs::Permissions>,
) -> Result<()> {
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .ok_or_else(|| CoreError::InvalidField {
            field: "path".into(),
            value: path.display().to_string(),
            expected: "a file path, not a directory".into(),
        })?;
    // A new file gets the usual 0666 less the umask (as `File::create` would), not the
    // temporary file's private 0600; an existing file keeps its own bits (set below).
    use std::os::unix::fs::PermissionsExt;
    let mut tmp = tempfile::Builder::new()
        .prefix(&format!(".{file_name}."))
        .suffix(".tmp")
        .permissions(std::fs::Permissions::from_mode(0o666))
        .tempfile_in(&parent)
        .map_err(|e| io_err("create a temporary file in", &parent)(without_temp_path(e)))?;
    tmp.write_all(bytes).map_err(io_err("write", tmp.path()))?;
    if let Some(perm) = permissions {
        tmp.as_file()
            .set_permissions(perm)
            .map_err(io_err("set permissions of", tmp.path()))?;
    }
    tmp.as_file()
        .sync_all()
        .map_err(io_err("sync", tmp.path()))?;
    tmp.persist(path).map_err(|e| CoreError::Io {
        action: "rename into",
        path: path.display().to_string(),
        source: e.error,
    })?;
    Ok(())
}

/// Opens an existing non-regular file (device, FIFO, socket) for writing and writes in place.
fn write_in_place(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .open(path)
        .map_err(io_err("open for writing", path))?;
    f.write_all(bytes).map_err(io_err("write", path))?;
    f.flush().map_err(io_err("flush", path))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn temp_dir(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("gearcomp-fsio-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn leftovers(dir: &Path) -> usize {
        std::fs::read_dir(dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
            .count()
    }

    #[test]
    fn writes_and_replaces_whole_file() {
        let dir = temp_dir("replace");
        let p = dir.join("out.txt");
        write_atomic(&p, b"first version, long").unwrap();
        write_atomic(&p, b"second").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"second");
        assert_eq!(leftovers(&dir), 0);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn directory_path_is_an_error_not_a_panic() {
        assert!(write_atomic(Path::new("/"), b"x").is_err());
        let dir = temp_dir("dir");
        let e = write_atomic(&dir, b"x").unwrap_err().to_string();
        assert!(e.contains("not a directory"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn dev_null_stays_a_device() {
        use std::os::unix::fs::FileTypeExt;
        write_atomic(Path::new("/dev/null"), b"discarded").unwrap();
        let meta = std::fs::metadata("/dev/null").unwrap();
        assert!(meta.file_type().is_char_device());
    }

    #[test]
    fn symlink_keeps_its_link_and_its_target_gets_the_bytes() {
        let dir = temp_dir("link");
        let target = dir.join("target.txt");
        std::fs::write(&target, b"old").unwrap();
        let link = dir.join("link.txt");
        std::os::unix::fs::symlink("target.txt", &link).unwrap();
        write_atomic(&link, b"new contents").unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read(&target).unwrap(), b"new contents");
        // A dangling link creates its target.
        let dangling = dir.join("dangling.txt");
        std::os::unix::fs::symlink(dir.join("made.txt"), &dangling).unwrap();
        write_atomic(&dangling, b"made").unwrap();
        assert_eq!(std::fs::read(dir.join("made.txt")).unwrap(), b"made");
        assert!(std::fs::symlink_metadata(&dangling)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(leftovers(&dir), 0);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn existing_file_keeps_its_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let dir = temp_dir("perm");
        let p = dir.join("model.toml");
        std::fs::write(&p, b"x").unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o640)).unwrap();
        write_atomic(&p, b"y").unwrap();
        let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o640);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn new_file_is_not_private() {
        use std::os::unix::fs::PermissionsExt;
        let dir = temp_dir("newperm");
        let p = dir.join("report.html");
        write_atomic(&p, b"<html>").unwrap();
        let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
        // 0666 less whatever umask the test runs under: at least the owner reads and writes,
        // and it is not the temporary file's 0600 unless the umask itself says so.
        assert_eq!(mode & 0o600, 0o600, "{mode:o}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn fifo_is_written_in_place() {
        let dir = temp_dir("fifo");
        let fifo = dir.join("pipe");
        let status = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap();
        assert!(status.success());
        let reader_path = fifo.clone();
        let reader = std::thread::spawn(move || std::fs::read(&reader_path).unwrap());
        write_atomic(&fifo, b"through the pipe").unwrap();
        assert_eq!(reader.join().unwrap(), b"through the pipe");
        use std::os::unix::fs::FileTypeExt;
        assert!(std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
