//! (owned by a helper)
