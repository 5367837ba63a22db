//! Sharing of large loaded files: one instance per canonical path while anything holds it, so
//! several scene elements naming the same (possibly gigabyte-sized) file load it once.

use crate::Result;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, Weak};

/// A per-type registry of weakly held instances, keyed by canonical path.
pub type SharedCache<T> = Mutex<Option<HashMap<PathBuf, Weak<T>>>>;

/// The instance for `path` from `cache` if one is still alive, otherwise `load(path)` (kept weakly).
/// Loading happens under the lock so concurrent users of one file load it once.
pub fn shared_by_path<T>(
    cache: &SharedCache<T>,
    path: &Path,
    load: impl FnOnce(&Path) -> Result<T>,
) -> Result<Arc<T>> {
    let key = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
    let mut guard = cache.lock().unwrap_or_else(|e| e.into_inner());
    let map = guard.get_or_insert_with(HashMap::new);
    if let Some(m) = map.get(&key).and_then(Weak::upgrade) {
        return Ok(m);
    }
    map.retain(|_, w| w.strong_count() > 0);
    let m = Arc::new(load(path)?);
    map.insert(key, Arc::downgrade(&m));
    Ok(m)
}
