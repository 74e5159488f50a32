//! Writing files so that a reader never sees half of one, and so that a process stopped
//! by a signal leaves nothing half-written behind.
//!
//! # Unfinished outputs
//!
//! Every writer of the workspace ([`write_atomically`], [`write_unfinished`] and the
//! data-set writers of `pgm-datasets`) registers a path *before* it creates it, in the
//! same critical section as the creation ([`create_unfinished`]), and takes it off the
//! list in the same critical section as the rename that finishes it ([`lock`]). A
//! signal handler that calls [`remove_unfinished`] therefore sees every temporary file,
//! every half-written data-set directory and every new pair file of a data-set
//! replacement that has not switched its index yet, and nothing finished.
//!
//! A process killed by SIGKILL cannot clean up; the next write into the same data-set
//! directory does (`pgm_datasets::format::JOURNAL_FILE`).
//!
//! The `pgm` command installs the handler: on SIGINT or SIGTERM it calls
//! [`remove_unfinished`], says on stderr what it removed and exits with status
//! 128 + the signal number (130, 143), the shell's convention.

use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The temporary sibling a file is written to before it is renamed into place:
/// `.NAME.PID.tmp` (hidden, named after the process so that it cannot be a file of the
/// user's).
///
/// # Errors
/// [`Error::InvalidParameter`] when `path` names no file (`/`, `..`).
pub fn temporary_path(path: &Path) -> Result<PathBuf> {
    let file_name = path.file_name().ok_or_else(|| Error::InvalidParameter {
        name: "output file path",
        value: path.display().to_string(),
        expected: "a path naming a file",
    })?;
    let mut temporary_name = std::ffi::OsString::from(".");
    temporary_name.push(file_name);
    temporary_name.push(format!(".{}.tmp", std::process::id()));
    Ok(path.with_file_name(temporary_name))
}

/// Where the bytes of a file given as text stop being UTF-8 (a binary or compressed
/// file): see [`read_utf8`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NotUtf8 {
    /// The line (from 1) of the first byte that is not UTF-8.
    pub line: usize,
    /// Its offset in the file.
    pub offset: usize,
    /// The byte itself.
    pub byte: u8,
}

/// Reads a whole file as UTF-8 text: the I/O error, or the text, or where its first
/// byte that is not UTF-8 stands (for the caller's own error, naming the file).
///
/// # Errors
/// The I/O error of reading `path`.
pub fn read_utf8(path: &Path) -> std::io::Result<std::result::Result<String, NotUtf8>> {
    let bytes = std::fs::read(path)?;
    Ok(String::from_utf8(bytes).map_err(|e| {
        let offset = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        NotUtf8 {
            line: 1 + bytes[..offset].iter().filter(|&&b| b == b'\n').count(),
            offset,
            byte: bytes[offset],
        }
    }))
}

/// Whether `name` is a temporary file of [`temporary_path`] for the file `of` (of any
/// process).
pub fn is_temporary_of(name: &str, of: &str) -> bool {
    name.strip_prefix('.')
        .and_then(|n| n.strip_prefix(of))
        .and_then(|n| n.strip_prefix('.'))
        .and_then(|n| n.strip_suffix(".tmp"))
        .is_some_and(|pid| !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit()))
}

/// Writes `bytes` to [`temporary_path`], flushed to disk, and renames it over `path`;
/// with `keep`, `path` stays registered as unfinished under the returned ticket (else
/// the ticket is already finished).
fn write_through_temporary(path: &Path, bytes: &[u8], keep: bool) -> Result<Ticket> {
    let temporary = temporary_path(path)?;
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| Error::Io { path, source }
    };
    let written = create_unfinished(&temporary, false, || -> Result<()> {
        let mut file = std::fs::File::create(&temporary).map_err(io(&temporary))?;
        file.write_all(bytes).map_err(io(&temporary))?;
        file.sync_all().map_err(io(&temporary))
    });
    let ticket = match written {
        Ok((ticket, ())) => ticket,
        Err(e) => {
            let _ = std::fs::remove_file(&temporary);
            return Err(e);
        }
    };
    let mut list = lock();
    match std::fs::rename(&temporary, path) {
        Ok(()) => {
            if keep {
                list.retarget(&ticket, path);
            } else {
                list.finish([&ticket]);
            }
            Ok(ticket)
        }
        Err(e) => {
            let _ = std::fs::remove_file(&temporary);
            list.finish([&ticket]);
            Err(io(path)(e))
        }
    }
}

/// Writes `bytes` to `path` atomically: into [`temporary_path`], flushed to disk, then
/// renamed over `path`. A reader sees the old file or the new one, never a mix; on
/// failure, or when the process is stopped by a signal that `pgm` handles, the
/// temporary file is removed and `path` is untouched.
///
/// # Errors
/// [`Error::InvalidParameter`] when `path` names no file (`/`, `..`), [`Error::Io`]
/// naming the file that could not be written or renamed.
pub fn write_atomically(path: impl AsRef<Path>, bytes: &[u8]) -> Result<()> {
    write_through_temporary(path.as_ref(), bytes, false).map(|_| ())
}

/// As [`write_atomically`], but `path` stays registered as unfinished until the
/// returned ticket is dropped (or finished under [`lock`]): a file that is only right
/// together with others still to be written, like a pair file of a data set before its
/// index names it. [`remove_unfinished`] removes it.
///
/// # Errors
/// As [`write_atomically`].
pub fn write_unfinished(path: impl AsRef<Path>, bytes: &[u8]) -> Result<Ticket> {
    write_through_temporary(path.as_ref(), bytes, true)
}

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard};

/// One registered path.
#[derive(Debug)]
struct Entry {
    id: u64,
    path: PathBuf,
    dir: bool,
}

static PENDING: Mutex<Vec<Entry>> = Mutex::new(Vec::new());
static NEXT_ID: AtomicU64 = AtomicU64::new(1);

fn pending() -> MutexGuard<'static, Vec<Entry>> {
    // A writer that panicked holding the lock leaves a list that is still right.
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

/// A registered path: while it lives, [`remove_unfinished`] removes the path. Dropping
/// it takes the path off the list (the owner has finished or removed it).
#[derive(Debug)]
#[must_use = "the path is unregistered when the ticket is dropped"]
pub struct Ticket {
    id: u64,
}

impl Drop for Ticket {
    fn drop(&mut self) {
        pending().retain(|e| e.id != self.id);
    }
}

/// The list, locked: registration, creation and renames happen under it, so that a
/// signal handler sees a path either finished or registered.
pub struct Locked(MutexGuard<'static, Vec<Entry>>);

impl Locked {
    /// Registers `path` (a directory when `dir`); the caller creates it while this lock
    /// is held.
    pub fn register(&mut self, path: &Path, dir: bool) -> Ticket {
        let id = NEXT_ID.fetch_add(1, Ordering::Relaxed);
        self.0.push(Entry {
            id,
            path: path.to_path_buf(),
            dir,
        });
        Ticket { id }
    }

    /// Points `ticket` at `path` (a temporary file renamed to its final name that is
    /// still unfinished, like a pair file before its index switch).
    pub fn retarget(&mut self, ticket: &Ticket, path: &Path) {
        if let Some(e) = self.0.iter_mut().find(|e| e.id == ticket.id) {
            e.path = path.to_path_buf();
        }
    }

    /// Takes `tickets` off the list now (their drop is then a no-op): for a rename that
    /// finishes several paths at once.
    pub fn finish<'a>(&mut self, tickets: impl IntoIterator<Item = &'a Ticket>) {
        for t in tickets {
            self.0.retain(|e| e.id != t.id);
        }
    }
}

/// Locks the list.
pub fn lock() -> Locked {
    Locked(pending())
}

/// Runs `create` with `path` registered under the lock; on failure the path is taken
/// off the list again (the caller removes whatever `create` left).
pub fn create_unfinished<T, E>(
    path: &Path,
    dir: bool,
    create: impl FnOnce() -> Result<T, E>,
) -> Result<(Ticket, T), E> {
    let mut list = lock();
    let ticket = list.register(path, dir);
    match create() {
        Ok(v) => Ok((ticket, v)),
        Err(e) => {
            list.finish([&ticket]);
            drop(list);
            Err(e)
        }
    }
}

/// Removes every registered path, newest first (files before the directory that holds
/// them; a directory only when it is empty, so nothing this process did not write is
/// ever removed), and returns how many existed. The list stays locked afterwards, so
/// no writer of this process creates anything more: call it only on the way out (the
/// signal handler of `pgm`, then `std::process::exit`).
pub fn remove_unfinished() -> usize {
    let list = pending();
    let mut removed = 0;
    for e in list.iter().rev() {
        let gone = if e.dir {
            std::fs::remove_dir(&e.path)
        } else {
            std::fs::remove_file(&e.path)
        };
        removed += usize::from(gone.is_ok());
    }
    // Held until the process exits: a writer blocked on it never creates its file.
    std::mem::forget(list);
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn read_utf8_names_the_line_and_offset_of_the_first_bad_byte() {
        let path = std::env::temp_dir().join(format!("pgm-fsutil-utf8-{}", std::process::id()));
        std::fs::write(&path, b"a\nb\nabc\xff\xfe\n").unwrap();
        let bad = read_utf8(&path).unwrap();
        std::fs::write(&path, "a\nb\n").unwrap();
        let good = read_utf8(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        let at = NotUtf8 {
            line: 3,
            offset: 7,
            byte: 0xff,
        };
        assert_eq!(bad, Err(at));
        assert_eq!(good.as_deref(), Ok("a\nb\n"));
        assert!(read_utf8(&path).is_err());
    }

    #[test]
    fn temporary_names_belong_to_their_file() {
        let t = temporary_path(Path::new("out/w.json")).unwrap();
        let name = t.file_name().unwrap().to_str().unwrap();
        assert!(is_temporary_of(name, "w.json"), "{name}");
        assert!(!is_temporary_of(name, "w"));
        assert!(is_temporary_of(".index.json.77.tmp", "index.json"));
        assert!(!is_temporary_of(".index.json.tmp", "index.json"));
        assert!(!is_temporary_of("index.json.77.tmp", "index.json"));
        assert!(!is_temporary_of(".index.json.7a.tmp", "index.json"));
    }

    #[test]
    fn replaces_the_file_and_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("pgm-fsutil-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("w.json");
        std::fs::write(&path, "old").unwrap();
        // A user's file with the old fixed temporary name is never touched.
        std::fs::write(dir.join("w.json.tmp"), "mine").unwrap();
        write_atomically(&path, b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
        assert_eq!(
            std::fs::read_to_string(dir.join("w.json.tmp")).unwrap(),
            "mine"
        );
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
        // A directory that does not exist: an error naming the temporary file, nothing written.
        let missing = dir.join("no-such-dir").join("w.json");
        let e = write_atomically(&missing, b"x").unwrap_err().to_string();
        assert!(e.contains("no-such-dir"), "{e}");
        assert!(write_atomically("/", b"x").is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
