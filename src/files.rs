//! Settings as files: a component's value in a RON file (its fields by their Rust names, read
//! through reflection), so a designer tunes a garment or a character's colliders without
//! recompiling. An entity with a [`FromFile<T>`] takes its `T` from the file when it loads and
//! again whenever it changes: with Bevy's `file_watcher` feature the asset server reloads an
//! edited file while the game runs. A file that does not parse is reported with its path and
//! the entity, which keeps the value it has.
//!
//! | component | file | an entity with it |
//! |---|---|---|
//! | [`ClothSettings`](crate::cloth::plugin::ClothSettings) | `.cloth.ron` | [`ClothSettingsFile`](crate::cloth::plugin::ClothSettingsFile) |
//! | [`BoneColliders`](crate::skeleton::plugin::BoneColliders) | `.colliders.ron` | [`BoneCollidersFile`](crate::skeleton::plugin::BoneCollidersFile) (the proxies are spawned again when it changes) |
//!
//! [`to_ron`] writes any value as a complete file to start from.

use std::marker::PhantomData;

use bevy::asset::io::Reader;
use bevy::asset::{
    Asset, AssetApp, AssetEvent, AssetId, AssetLoadFailedEvent, AssetLoader, Assets, Handle,
    LoadContext,
};
use bevy::ecs::reflect::AppTypeRegistry;
use bevy::prelude::*;
use bevy::reflect::serde::{TypedReflectDeserializer, TypedReflectSerializer};
use bevy::reflect::{FromReflect, GetTypeRegistration, TypePath, TypeRegistry, TypeRegistryArc};
use serde::de::DeserializeSeed;

use crate::schedule::DrapeSystems;

/// A component whose value can come from a RON file.
pub trait FileValue:
    Component<Mutability = bevy::ecs::component::Mutable>
    + Reflect
    + FromReflect
    + TypePath
    + GetTypeRegistration
    + Clone
    + PartialEq
{
    /// The file extension, without the leading dot.
    const EXTENSION: &'static str;
}

/// A `T` loaded from a file.
#[derive(Asset, TypePath, Clone, Debug, PartialEq)]
pub struct FileAsset<T: FileValue>(pub T);

/// On an entity: take its `T` from this file, now and whenever it changes.
#[derive(Component, Clone, Debug, PartialEq)]
pub struct FromFile<T: FileValue>(pub Handle<FileAsset<T>>);

impl<T: FileValue> FromFile<T> {
    /// The entity's `T` from the file `handle` loads (`server.load("x.cloth.ron")`).
    pub fn new(handle: Handle<FileAsset<T>>) -> Self {
        Self(handle)
    }
}

/// Why a file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    /// The file could not be read.
    #[error("cannot read the file: {0}")]
    Io(#[from] std::io::Error),
    /// It is not RON, or not a value of the type.
    #[error("not a {type_name} in RON: {message}")]
    Parse {
        /// The type expected.
        type_name: &'static str,
        /// What was wrong.
        message: String,
    },
}

fn parse_error<T: FileValue>(message: impl ToString) -> FileError {
    FileError::Parse {
        type_name: T::short_type_path(),
        message: message.to_string(),
    }
}

/// Reads a `T` from RON (as [`to_ron`] writes it). `registry` must have `T` registered.
pub fn from_ron<T: FileValue>(text: &str, registry: &TypeRegistry) -> Result<T, FileError> {
    let mut deserializer = ron::de::Deserializer::from_str(text).map_err(parse_error::<T>)?;
    let reflected = TypedReflectDeserializer::of::<T>(registry)
        .deserialize(&mut deserializer)
        .map_err(parse_error::<T>)?;
    T::from_reflect(reflected.as_ref())
        .ok_or_else(|| parse_error::<T>("the fields do not make one"))
}

/// Writes `value` as RON, every field by name.
pub fn to_ron<T: FileValue>(value: &T, registry: &TypeRegistry) -> Result<String, FileError> {
    let serializer = TypedReflectSerializer::new(value, registry);
    ron::ser::to_string_pretty(&serializer, ron::ser::PrettyConfig::default())
        .map_err(parse_error::<T>)
}

/// Loads files of `T::EXTENSION` as [`FileAsset<T>`]s.
#[derive(TypePath)]
struct FileLoader<T: FileValue> {
    registry: TypeRegistryArc,
    value: PhantomData<fn() -> T>,
}

impl<T: FileValue> FromWorld for FileLoader<T> {
    fn from_world(world: &mut World) -> Self {
        Self {
            registry: world.resource::<AppTypeRegistry>().0.clone(),
            value: PhantomData,
        }
    }
}

impl<T: FileValue> AssetLoader for FileLoader<T> {
    type Asset = FileAsset<T>;
    type Settings = ();
    type Error = FileError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        _context: &mut LoadContext<'_>,
    ) -> Result<FileAsset<T>, FileError> {
        let mut bytes = Vec::new();
        reader.read_to_end(&mut bytes).await?;
        let text = std::str::from_utf8(&bytes).map_err(parse_error::<T>)?;
        let registry = self.registry.read();
        from_ron::<T>(text, &registry).map(FileAsset)
    }

    fn extensions(&self) -> &[&str] {
        std::slice::from_ref(&T::EXTENSION)
    }
}

/// Lets entities take their `T` from files: the asset, its loader and the system that copies
/// a file into the entities naming it, in `schedule` before `before`.
pub(crate) fn add_file_type<T: FileValue, M>(
    app: &mut App,
    schedule: impl bevy::ecs::schedule::ScheduleLabel + Clone,
    before: impl IntoScheduleConfigs<bevy::ecs::system::ScheduleSystem, M>,
) {
    app.register_type::<T>().init_asset::<FileAsset<T>>();
    let loader = FileLoader::<T>::from_world(app.world_mut());
    app.register_asset_loader(loader).add_systems(
        schedule,
        (apply_files::<T>, before)
            .chain()
            .in_set(DrapeSystems::Prepare),
    );
}

/// Copies a file into every entity that names it, when the entity gets the file and when the
/// file loads or changes.
fn apply_files<T: FileValue>(
    mut commands: Commands,
    mut events: MessageReader<AssetEvent<FileAsset<T>>>,
    mut failed: MessageReader<AssetLoadFailedEvent<FileAsset<T>>>,
    files: Res<Assets<FileAsset<T>>>,
    entities: Query<(Entity, &FromFile<T>, Option<&T>)>,
    added: Query<(), Added<FromFile<T>>>,
) {
    for failure in failed.read() {
        for (entity, file, _) in &entities {
            if file.0.id() == failure.id {
                warn!(
                    "entity {entity}: its file {} did not load ({}); it keeps the {} it has",
                    failure.path,
                    failure.error,
                    T::short_type_path()
                );
            }
        }
    }
    let changed: Vec<AssetId<FileAsset<T>>> = events
        .read()
        .filter_map(|e| match e {
            AssetEvent::Added { id } | AssetEvent::Modified { id } => Some(*id),
            _ => None,
        })
        .collect();
    for (entity, file, current) in &entities {
        let id = file.0.id();
        if !changed.contains(&id) && !added.contains(entity) {
            continue;
        }
        if let Some(asset) = files.get(id)
            && current != Some(&asset.0)
        {
            commands.entity(entity).insert(asset.0.clone());
        }
    }
}
