//! Scratch folders for tests that write files: each is a fresh folder under the system's
//! temporary directory, removed when its guard drops — also when the test fails and
//! unwinds — so test runs leave nothing behind.

use std::ops::Deref;
use std::path::Path;

/// A scratch folder, removed when dropped; derefs to its path.
pub struct Dir(tempfile::TempDir);

impl Deref for Dir {
    type Target = Path;
    fn deref(&self) -> &Path {
        self.0.path()
    }
}

impl AsRef<Path> for Dir {
    fn as_ref(&self) -> &Path {
        self.0.path()
    }
}

/// A new scratch folder whose name starts with `lash-{purpose}-`.
pub fn dir(purpose: &str) -> Dir {
    Dir(tempfile::Builder::new()
        .prefix(&format!("lash-{purpose}-"))
        .tempdir()
        .expect("a scratch folder can be made in the temporary directory"))
}
