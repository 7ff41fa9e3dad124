//! Scenes: what the world holds when the server starts.
//!
//! A scene file (RON or JSON, chosen by extension) is read into the serde
//! types of [`schema`], checked, and built into a physics [`World`] plus an
//! [`EntityTable`] that gives every streamed body and particle a stable
//! entity id. Errors name the offending entry by path
//! (`bodies[3].shape.radius`) and say why, for syntax errors (through
//! `serde_path_to_error`) and for meaning alike (an unknown body in a joint,
//! a negative radius, a duplicate name, NaN).
//!
//! `docs/scene-format.md` documents every field; `server/scenes/` holds
//! examples, and [`demo::demo_scene`] is the built-in demo.

mod build;
pub mod demo;
pub mod entities;
pub mod point_sets;
pub mod schema;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use inertia_physics::glam::DVec3;
use inertia_physics::{BodyHandle, FluidHandle, PhysicsError, SoftBodyHandle, World, WorldConfig};

pub use entities::{shape_desc, Entity, EntitySource, EntityTable};
pub use schema::SceneFile;

/// The syntax a scene is written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SceneFormat {
    /// Rusty Object Notation (`.ron`), with the `implicit_some` and
    /// `unwrap_variant_newtypes` extensions on.
    Ron,
    /// JSON (`.json`).
    Json,
}

impl SceneFormat {
    /// The format a file's extension names, if any.
    pub fn from_path(path: &Path) -> Option<SceneFormat> {
        match path.extension()?.to_str()?.to_ascii_lowercase().as_str() {
            "ron" => Some(SceneFormat::Ron),
            "json" => Some(SceneFormat::Json),
            _ => None,
        }
    }
}

/// Why a scene was refused.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("cannot read scene {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The extension is neither `.ron` nor `.json`.
    #[error("scene {0}: unknown format (use a .ron or .json file)")]
    UnknownFormat(PathBuf),
    /// The text does not parse into a scene.
    #[error("scene syntax error at `{at}`: {message}")]
    Parse {
        /// Path of the offending entry (`.` for the whole document).
        at: String,
        /// What is wrong.
        message: String,
    },
    /// An entry parses but makes no sense.
    #[error("scene error at `{at}`: {why}")]
    Invalid {
        /// Path of the offending entry, e.g. `joints[2].b`.
        at: String,
        /// What is wrong and what to do.
        why: String,
    },
    /// The physics engine refused an entry.
    #[error("scene error at `{at}`: {source}")]
    Physics {
        /// Path of the entry.
        at: String,
        /// The engine's reason.
        source: PhysicsError,
    },
    /// An error in a named file.
    #[error("{path}: {source}")]
    InFile {
        /// The file.
        path: PathBuf,
        /// The error.
        source: Box<SceneError>,
    },
}

impl SceneError {
    /// This error, as one in the file at `path`.
    pub fn in_file(self, path: &Path) -> SceneError {
        SceneError::InFile {
            path: path.into(),
            source: Box::new(self),
        }
    }

    /// The limit, when the engine refused a body past
    /// [`WorldConfig::max_bodies`].
    pub fn body_limit(&self) -> Option<usize> {
        match self {
            SceneError::Physics {
                source: PhysicsError::TooManyBodies { max },
                ..
            } => Some(*max),
            SceneError::InFile { source, .. } => source.body_limit(),
            _ => None,
        }
    }

    /// The path of the offending entry, when the error has one.
    pub fn at(&self) -> Option<&str> {
        match self {
            SceneError::Parse { at, .. }
            | SceneError::Invalid { at, .. }
            | SceneError::Physics { at, .. } => Some(at),
            SceneError::InFile { source, .. } => source.at(),
            _ => None,
        }
    }
}

/// A parsed and checked scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The scene's content.
    pub file: SceneFile,
}

/// A built scene: the world, what clients see of it, and where players go.
#[derive(Debug)]
pub struct BuiltScene {
    /// The physics world (not stepped yet: tick 0).
    pub world: World,
    /// Every streamed body and particle, ids from 1 in build order.
    pub entities: EntityTable,
    /// Every named body (explicit, generated and ragdoll part names).
    pub bodies_by_name: BTreeMap<String, BodyHandle>,
    /// Every XPBD soft body (`soft_bodies`), by name. They are not in
    /// `entities`.
    pub soft_bodies_by_name: BTreeMap<String, SoftBodyHandle>,
    /// Every fluid (`fluids`), by name. They are not in `entities`.
    pub fluids_by_name: BTreeMap<String, FluidHandle>,
    /// Where avatars appear, m.
    pub spawn_points: Vec<DVec3>,
    /// The scene's name.
    pub name: String,
}

impl Scene {
    /// Reads, parses and checks a scene file; the format follows the
    /// extension. Errors name the file and the offending entry.
    pub fn load(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
        let path = path.as_ref();
        let scene = Scene::read_file(path)?;
        scene.check().map_err(|e| e.in_file(path))?;
        Ok(scene)
    }

    /// Reads and parses a scene file without building it, so that the one
    /// build that follows ([`Scene::build_with`]) does the checking, under
    /// its configuration's body limit. Errors name the file.
    pub fn read_file(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
        let path = path.as_ref();
        let format =
            SceneFormat::from_path(path).ok_or_else(|| SceneError::UnknownFormat(path.into()))?;
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
            path: path.into(),
            source,
        })?;
        Scene::read(&text, format).map_err(|e| e.in_file(path))
    }

    /// Parses and checks scene text.
    pub fn parse(text: &str, format: SceneFormat) -> Result<Scene, SceneError> {
        let scene = Scene::read(text, format)?;
        scene.check()?;
        Ok(scene)
    }

    /// Parses scene text without building it: syntax and types are
    /// checked here, meaning (names, joints, ranges, the body limit) by
    /// the build. A server builds its scene once this way, so a file that
    /// makes millions of bodies is refused at the body past
    /// [`WorldConfig::max_bodies`] rather than built whole first.
    pub fn read(text: &str, format: SceneFormat) -> Result<Scene, SceneError> {
        let file = match format {
            SceneFormat::Ron => parse_ron(text)?,
            SceneFormat::Json => parse_json(text)?,
        };
        Ok(Scene { file })
    }

    /// Builds the world with the default world configuration.
    pub fn build(&self) -> Result<BuiltScene, SceneError> {
        self.build_with(WorldConfig::default())
    }

    /// Builds the world with `config` (thread count, energy accounting).
    pub fn build_with(&self, config: WorldConfig) -> Result<BuiltScene, SceneError> {
        build::build(&self.file, config)
    }

    /// Checks everything that building checks, without keeping the result.
    fn check(&self) -> Result<(), SceneError> {
        build::build(
            &self.file,
            WorldConfig {
                threads: 1,
                energy_accounting: false,
                gpu_readback_every_step: false,
                ..WorldConfig::default()
            },
        )
        .map(|_| ())
    }
}

/// The path serde_path_to_error found, without enum variant names (so a
/// sphere's radius is `bodies[3].shape.radius`, not `…shape.Sphere.radius`).
fn path_string(path: &serde_path_to_error::Path) -> String {
    use serde_path_to_error::Segment;
    let mut s = String::new();
    for seg in path.iter() {
        match seg {
            Segment::Seq { index } => s.push_str(&format!("[{index}]")),
            Segment::Map { key } => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(key);
            }
            Segment::Enum { .. } => {}
            Segment::Unknown => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push('?');
            }
        }
    }
    if s.is_empty() {
        ".".into()
    } else {
        s
    }
}

fn parse_ron(text: &str) -> Result<SceneFile, SceneError> {
    use ron::extensions::Extensions;
    let options = ron::Options::default()
        .with_default_extension(Extensions::IMPLICIT_SOME)
        .with_default_extension(Extensions::UNWRAP_VARIANT_NEWTYPES);
    let mut de = ron::Deserializer::from_str_with_options(text, &options).map_err(|e| {
        SceneError::Parse {
            at: ".".into(),
            message: e.to_string(),
        }
    })?;
    let file: SceneFile = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let at = path_string(e.path());
        let message = e.into_inner().to_string();
        SceneError::Parse { at, message }
    })?;
    de.end().map_err(|e| SceneError::Parse {
        at: ".".into(),
        message: format!("{e} (text after the scene)"),
    })?;
    Ok(file)
}

fn parse_json(text: &str) -> Result<SceneFile, SceneError> {
    let mut de = serde_json::Deserializer::from_str(text);
    let file: SceneFile = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let at = path_string(e.path());
        let message = e.into_inner().to_string();
        SceneError::Parse { at, message }
    })?;
    de.end().map_err(|e| SceneError::Parse {
        at: ".".into(),
        message: e.to_string(),
    })?;
    Ok(file)
}
