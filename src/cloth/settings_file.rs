//! Cloth settings as assets: a `.cloth.ron` file holds a [`ClothSettings`] in RON (its fields
//! by their Rust names, read through reflection), so a designer tunes a garment without
//! recompiling. A cloth with a [`ClothSettingsFile`] takes its settings from the file when it
//! loads and again whenever it changes: with Bevy's `file_watcher` feature the asset server
//! reloads an edited file while the game runs. A file that does not parse is reported with
//! its path and the cloth's entity, and the cloth keeps the settings it has.

use bevy::asset::io::Reader;
use bevy::asset::{
    Asset, AssetEvent, AssetId, AssetLoadFailedEvent, AssetLoader, Assets, Handle, LoadContext,
};
use bevy::ecs::reflect::AppTypeRegistry;
use bevy::prelude::*;
use bevy::reflect::serde::{TypedReflectDeserializer, TypedReflectSerializer};
use bevy::reflect::{FromReflect, TypePath, TypeRegistryArc};
use serde::de::DeserializeSeed;

use super::plugin::ClothSettings;

/// A [`ClothSettings`] loaded from a `.cloth.ron` file.
#[derive(Asset, TypePath, Clone, Debug, PartialEq)]
pub struct ClothSettingsAsset(pub ClothSettings);

/// On a cloth: take its [`ClothSettings`] from this file, now and whenever it changes.
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component)]
pub struct ClothSettingsFile(pub Handle<ClothSettingsAsset>);

/// Why a settings file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum SettingsFileError {
    /// The file could not be read.
    #[error("cannot read the file: {0}")]
    Io(#[from] std::io::Error),
    /// It is not RON, or not a `ClothSettings`.
    #[error("not a ClothSettings in RON: {0}")]
    Parse(String),
}

/// Reads `ron` (a [`ClothSettings`] written as [`settings_to_ron`] writes it).
pub fn settings_from_ron(
    ron_text: &str,
    registry: &bevy::reflect::TypeRegistry,
) -> Result<ClothSettings, SettingsFileError> {
    let mut deserializer = ron::de::Deserializer::from_str(ron_text)
        .map_err(|e| SettingsFileError::Parse(e.to_string()))?;
    let reflected = TypedReflectDeserializer::of::<ClothSettings>(registry)
        .deserialize(&mut deserializer)
        .map_err(|e| SettingsFileError::Parse(e.to_string()))?;
    ClothSettings::from_reflect(reflected.as_ref()).ok_or_else(|| {
        SettingsFileError::Parse("the fields do not make a ClothSettings".to_string())
    })
}

/// Writes `settings` as RON, every field by name: a complete file to start a garment's from.
pub fn settings_to_ron(
    settings: &ClothSettings,
    registry: &bevy::reflect::TypeRegistry,
) -> Result<String, SettingsFileError> {
    let serializer = TypedReflectSerializer::new(settings, registry);
    ron::ser::to_string_pretty(&serializer, ron::ser::PrettyConfig::default())
        .map_err(|e| SettingsFileError::Parse(e.to_string()))
}

/// Loads `.cloth.ron` files as [`ClothSettingsAsset`]s.
#[derive(TypePath)]
pub(crate) struct ClothSettingsLoader {
    registry: TypeRegistryArc,
}

impl FromWorld for ClothSettingsLoader {
    fn from_world(world: &mut World) -> Self {
        Self {
            registry: world.resource::<AppTypeRegistry>().0.clone(),
        }
    }
}

impl AssetLoader for ClothSettingsLoader {
    type Asset = ClothSettingsAsset;
    type Settings = ();
    type Error = SettingsFileError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        _context: &mut LoadContext<'_>,
    ) -> Result<ClothSettingsAsset, SettingsFileError> {
        let mut bytes = Vec::new();
        reader.read_to_end(&mut bytes).await?;
        let text =
            std::str::from_utf8(&bytes).map_err(|e| SettingsFileError::Parse(e.to_string()))?;
        let registry = self.registry.read();
        settings_from_ron(text, &registry).map(ClothSettingsAsset)
    }

    fn extensions(&self) -> &[&str] {
        &["cloth.ron"]
    }
}

/// Copies a settings file into every cloth that names it, when the cloth gets the file and
/// when the file loads or changes.
pub(crate) fn apply_settings_files(
    mut commands: Commands,
    mut events: MessageReader<AssetEvent<ClothSettingsAsset>>,
    files: Res<Assets<ClothSettingsAsset>>,
    mut failed: MessageReader<AssetLoadFailedEvent<ClothSettingsAsset>>,
    cloths: Query<(Entity, &ClothSettingsFile, Option<&ClothSettings>)>,
    added: Query<(), Added<ClothSettingsFile>>,
) {
    for failure in failed.read() {
        for (entity, file, _) in &cloths {
            if file.0.id() == failure.id {
                warn!(
                    "cloth {entity}: its settings file {} did not load ({}); it keeps the \
                     settings it has",
                    failure.path, failure.error
                );
            }
        }
    }
    let changed: Vec<AssetId<ClothSettingsAsset>> = events
        .read()
        .filter_map(|e| match e {
            AssetEvent::Added { id } | AssetEvent::Modified { id } => Some(*id),
            _ => None,
        })
        .collect();
    for (entity, file, current) in &cloths {
        let id = file.0.id();
        if !changed.contains(&id) && !added.contains(entity) {
            continue;
        }
        match files.get(id) {
            Some(asset) if current != Some(&asset.0) => {
                commands.entity(entity).insert(asset.0);
            }
            _ => {}
        }
    }
}
