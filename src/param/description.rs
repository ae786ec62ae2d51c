//! A scene as read from a file, before it is built: the root table of raylab's format.

use crate::param::error::Loc;
use crate::param::value::Table;

/// A scene as read from a file, before building: the root table in raylab's format.
#[derive(Clone, Debug)]
pub struct SceneDescription {
    /// Scene name (the file stem unless the file sets `name`).
    pub name: String,
    /// The root table (keys as in the TOML format).
    pub root: Table,
    /// Location of the whole document.
    pub loc: Loc,
}
