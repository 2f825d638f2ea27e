//! Reading and writing triangle meshes and point clouds in OBJ, STL and PLY.
//!
//! The readers turn a file into a [`RawGeometry`]: finite positions, optional
//! per-vertex normals and 0-based triangle indices that are guaranteed to be in
//! range. Polygons are fan-triangulated, STL triangle soup is welded into an
//! indexed mesh, and a file without faces becomes a point cloud.
//!
//! The readers never panic on malformed input and never allocate more than a
//! small multiple of the input size: element counts claimed by a header are
//! checked against the bytes that are actually present before anything is
//! reserved.
//!
//! Conventions used in error messages: line numbers are 1-based, byte offsets
//! are 0-based from the start of the file, vertex and face numbers of PLY and
//! STL files are 0-based, OBJ vertices are reported with their 1-based OBJ
//! number, and OBJ faces are 0-based but always come with their line.
//!
//! This file holds the shared types, errors and helpers and [`load_geometry`];
//! each format has its own submodule (`obj`, `stl`, `ply`).

use std::fmt;
use std::io;
use std::path::{Path, PathBuf};

mod obj;
mod ply;
mod stl;

pub use obj::{parse_obj, write_obj};
pub use ply::{parse_ply, write_ply};
pub use stl::parse_stl;

/// Geometry as read from a file: a triangle mesh, or a bare point cloud when `triangles` is empty.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RawGeometry {
    /// Vertex positions; the readers guarantee that every coordinate is finite.
    pub positions: Vec<[f64; 3]>,
    /// One normal per position, when the file has them (PLY `nx ny nz`; OBJ `vn`
    /// only if exactly one normal can be assigned to every vertex, otherwise `None`).
    pub normals: Option<Vec<[f64; 3]>>,
    /// Triangles as 0-based indices into `positions`; the readers guarantee they are in range.
    pub triangles: Vec<[u32; 3]>,
}

/// What the number `line_or_offset` of a [`LoadError::Parse`] counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LocationKind {
    /// A 1-based line number in a text file or a text header.
    Line,
    /// A 0-based byte offset from the start of a binary file.
    ByteOffset,
}

impl fmt::Display for LocationKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LocationKind::Line => "line",
            LocationKind::ByteOffset => "byte offset",
        })
    }
}

/// Why a file could not be turned into a [`RawGeometry`].
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read from disk.
    #[error("cannot read `{}`: {source}", .path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: io::Error,
    },

    /// The file name has no extension, or one that is not `.obj`, `.stl` or `.ply`.
    #[error(
        "cannot tell the geometry format of `{}`: the extension must be .obj, .stl or .ply (any case)",
        .path.display()
    )]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },

    /// The content does not follow the format's syntax.
    #[error("{format} parse error at {kind} {line_or_offset}: {message}")]
    Parse {
        /// "OBJ", "STL" or "PLY".
        format: &'static str,
        /// What `line_or_offset` counts.
        kind: LocationKind,
        /// Where the error is: a 1-based line or a 0-based byte offset.
        line_or_offset: usize,
        /// What is wrong there.
        message: String,
    },

    /// A face refers to a vertex that does not exist. `index` is the index as
    /// written in the file (1-based or negative for OBJ, 0-based for PLY), `face`
    /// is the 0-based number of the face.
    #[error(
        "{format}: {location} refers to vertex index {index}, but only {vertex_count} vertices are available"
    )]
    IndexOutOfRange {
        /// "OBJ" or "PLY".
        format: &'static str,
        /// The face's 0-based number.
        face: usize,
        /// The index as written in the file.
        index: i64,
        /// The vertices available to it.
        vertex_count: usize,
        /// The face in words, with its line or byte offset ("face 3 (line 12)").
        location: String,
    },

    /// A vertex position has a NaN or infinite coordinate. `index` is the 0-based
    /// vertex number (for STL: `3 * facet + corner`, counted before welding).
    #[error(
        "{format}: {location} has a non-finite coordinate ({}, {}, {})",
        .position[0], .position[1], .position[2]
    )]
    NonFinite {
        /// "OBJ", "STL" or "PLY".
        format: &'static str,
        /// The vertex's 0-based number.
        index: usize,
        /// Its coordinates as read.
        position: [f64; 3],
        /// The vertex in words, with its line or byte offset ("vertex 2 (line 2)").
        location: String,
    },

    /// The data ends before everything the file declares (a header count, a
    /// list length) has been read.
    #[error(
        "{format}: file is truncated: {what} needs at least {expected} {unit}, but only {got} are present"
    )]
    Truncated {
        /// "STL" or "PLY".
        format: &'static str,
        /// The part that is cut short.
        what: String,
        /// How many `unit`s it needs at least.
        expected: u64,
        /// How many are present.
        got: u64,
        /// "bytes" or "values".
        unit: &'static str,
    },

    /// The file is empty or defines no vertex at all.
    #[error("{format}: the file contains no vertices")]
    Empty {
        /// "OBJ", "STL" or "PLY".
        format: &'static str,
    },
}

fn parse_error(
    format: &'static str,
    kind: LocationKind,
    line_or_offset: usize,
    message: impl Into<String>,
) -> LoadError {
    LoadError::Parse {
        format,
        kind,
        line_or_offset,
        message: message.into(),
    }
}

fn line_error(format: &'static str, line: usize, message: impl Into<String>) -> LoadError {
    parse_error(format, LocationKind::Line, line, message)
}

fn check_finite(
    format: &'static str,
    index: usize,
    position: [f64; 3],
    location: impl FnOnce() -> String,
) -> Result<(), LoadError> {
    if position.iter().all(|c| c.is_finite()) {
        Ok(())
    } else {
        Err(LoadError::NonFinite {
            format,
            index,
            position,
            location: location(),
        })
    }
}

fn to_u64(n: usize) -> u64 {
    u64::try_from(n).unwrap_or(u64::MAX)
}

fn is_blank(bytes: &[u8]) -> bool {
    bytes.iter().all(u8::is_ascii_whitespace)
}

/// Loads a mesh or point cloud, choosing the parser by the file extension
/// (`.obj`, `.stl`, `.ply`, case-insensitive).
pub fn load_geometry(path: &Path) -> Result<RawGeometry, LoadError> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let parse: fn(&[u8]) -> Result<RawGeometry, LoadError> = match extension.as_deref() {
        Some("obj") => parse_obj,
        Some("stl") => parse_stl,
        Some("ply") => parse_ply,
        _ => {
            return Err(LoadError::UnknownFormat {
                path: path.to_path_buf(),
            });
        }
    };
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse(&bytes)
}

/// Reads three numbers from `tokens` (further tokens are left alone).
fn parse_vec3<'a>(
    format: &'static str,
    tokens: &mut impl Iterator<Item = &'a str>,
    what: &str,
    line: usize,
) -> Result<[f64; 3], LoadError> {
    let mut v = [0.0; 3];
    for (axis, c) in v.iter_mut().enumerate() {
        let token = tokens.next().ok_or_else(|| {
            line_error(
                format,
                line,
                format!("{what} has {axis} coordinates, but 3 are needed"),
            )
        })?;
        *c = token.parse().map_err(|_| {
            line_error(
                format,
                line,
                format!("{what} coordinate `{token}` is not a number"),
            )
        })?;
    }
    Ok(v)
}

fn invalid_input(message: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, message)
}

/// Checks what every writer needs: normals per vertex and triangle indices in range.
fn validate_for_writing(geometry: &RawGeometry, max_index: u64) -> io::Result<()> {
    let n = geometry.positions.len();
    if let Some(normals) = &geometry.normals {
        if normals.len() != n {
            return Err(invalid_input(format!(
                "geometry has {} normals for {n} positions",
                normals.len()
            )));
        }
    }
    for (t, tri) in geometry.triangles.iter().enumerate() {
        for &i in tri {
            if u64::from(i) >= to_u64(n) || u64::from(i) > max_index {
                return Err(invalid_input(format!(
                    "triangle {t} refers to vertex {i}, but there are only {n} vertices"
                )));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod test_util;
#[cfg(test)]
mod tests;
