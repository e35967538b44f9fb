//! A hinge rig, a body skinned to it and its clips written as a glTF 2.0 binary (`.glb`), so a
//! character of the crate can be loaded like any other model and animated by Bevy's
//! `AnimationPlayer`. `assets/characters/humanoid.glb` is [`humanoid_glb`] (written by
//! `cargo run --example generate_character`).
//!
//! - One node per bone, named after it, in the rig's hierarchy under a root node: the bone's
//!   rest translation (its offset) and, in the clips, its rotation (the hinge's) and for the
//!   root its translation too. Every bone is a joint of one skin.
//! - The body ([`BodyPart`]s): one capsule per
//!   [`BoneProxy`](bevy_drape::skeleton::humanoid::BoneProxy) (the shapes the cloth collides with) and a box per
//!   foot, each vertex bound to its bone with weight 1, in the rest pose; the inverse bind
//!   matrices are the bones' rest transforms inverted. In the rest pose every hinge is at 0
//!   and the root is where the first clip starts.
//! - Each clip is sampled at a fixed rate with linear interpolation (spherical for rotations):
//!   between samples the file's rotation is within a small fraction of a degree of the
//!   crate's spline.

use bevy::math::{Mat4, Quat, Vec3};
use bevy::mesh::{Indices, Mesh, MeshBuilder, VertexAttributeValues};
use bevy::prelude::{Capsule3d, Cuboid, Meshable, Transform};
use bevy_drape::prelude::humanoid;
use bevy_drape::skeleton::clip::{Clip, ClipDesc};
use bevy_drape::skeleton::humanoid::humanoid_proxies;
use bevy_drape::skeleton::rig::Rig;
use bevy_drape::skeleton::rig::{BoneState, Pose, PoseRate};
use serde_json::{Value, json};

/// Samples per second of the clips in the file.
pub const SAMPLE_HZ: f32 = 60.0;

/// The humanoid (its rig, a body of its collision proxies' shapes with feet, and the walk
/// and wave clips, named `walk` and `wave`) as a `.glb` file.
pub fn humanoid_glb() -> Vec<u8> {
    let rig = humanoid();
    let clip = |text: &str| {
        Clip::new(
            &ClipDesc::from_ron(text).expect("the crate's clips parse"),
            &rig,
        )
        .expect("the crate's clips bind to the humanoid")
    };
    let walk = clip(include_str!("../../../assets/clips/walk.clip.ron"));
    let wave = clip(include_str!("../../../assets/clips/wave.clip.ron"));
    // The proxies' capsules, and a box per foot (no proxy: cloth does not reach the feet).
    let mut parts: Vec<BodyPart> = humanoid_proxies()
        .iter()
        .map(|proxy| BodyPart {
            bone: proxy.bone.clone(),
            mesh: Capsule3d::new(proxy.radius, 2.0 * proxy.half_length)
                .mesh()
                .longitudes(16)
                .latitudes(8)
                .build(),
            placement: Transform::from_translation(proxy.centre).with_rotation(proxy.rotation()),
        })
        .collect();
    let (radius, half_length) = (0.04f32, 0.07f32);
    for side in ["l", "r"] {
        parts.push(BodyPart {
            bone: format!("foot_{side}"),
            mesh: Cuboid::new(2.0 * radius, 1.5 * radius, 2.0 * (half_length + radius))
                .mesh()
                .build(),
            placement: Transform::from_xyz(0.0, -0.01, 0.05),
        });
    }
    export_glb(&rig, &parts, &[("walk", &walk), ("wave", &wave)], SAMPLE_HZ)
}

/// A piece of a character's body: a mesh rigidly bound to one bone.
pub struct BodyPart {
    /// The bone's name.
    pub bone: String,
    /// The mesh, in its own frame (positions and normals are read).
    pub mesh: Mesh,
    /// Where the mesh sits in the bone's frame.
    pub placement: Transform,
}

/// `rig` with a body of `parts` (each skinned rigidly to its bone; parts naming no bone are
/// left out) and `clips` sampled at `hz`, as a `.glb` file.
pub fn export_glb(rig: &Rig, parts: &[BodyPart], clips: &[(&str, &Clip)], hz: f32) -> Vec<u8> {
    let mut file = GlbBuilder::default();
    let bones = rig.bones();
    let n = bones.len();
    // Node 0 is the character (named `humanoid`), nodes 1..=n the bones, node n + 1 the body.
    // The rest (bind) pose: every hinge at 0, the root where the first clip starts, so the
    // model stands on the ground before it is animated.
    let mut rest_pose = rig.rest_pose();
    if let Some((_, clip)) = clips.first() {
        let mut pose = rig.rest_pose();
        clip.sample(0.0, &mut pose, &mut PoseRate::default());
        rest_pose.root_translation = pose.root_translation;
    }
    let mut rest = Vec::new();
    rig.forward(&rest_pose, None, &mut rest);
    let mut nodes = vec![json!({ "name": "humanoid", "children": [1, n + 1] })];
    for (b, bone) in bones.iter().enumerate() {
        let children: Vec<usize> = (0..n)
            .filter(|&c| bones[c].parent == Some(b))
            .map(|c| c + 1)
            .collect();
        let local = local_transform(&rest, rig, b);
        let mut node = json!({
            "name": bone.name,
            "translation": local.0.to_array(),
            "rotation": local.1.to_array(),
        });
        if !children.is_empty() {
            node["children"] = json!(children);
        }
        nodes.push(node);
    }
    nodes.push(json!({ "name": "body", "mesh": 0, "skin": 0 }));

    // The body in the rest pose.
    let (mut positions, mut normals, mut joints, mut indices) = (vec![], vec![], vec![], vec![]);
    for part in parts {
        let Some(bone) = rig.find(&part.bone) else {
            continue;
        };
        let mesh = &part.mesh;
        let (Some(VertexAttributeValues::Float32x3(p)), Some(VertexAttributeValues::Float32x3(m))) = (
            mesh.attribute(Mesh::ATTRIBUTE_POSITION),
            mesh.attribute(Mesh::ATTRIBUTE_NORMAL),
        ) else {
            continue;
        };
        let in_bone = part.placement.rotation;
        let world = rest[bone].rotation;
        let first = positions.len() as u32;
        for (p, m) in p.iter().zip(m) {
            let local = part.placement.translation + in_bone * Vec3::from(*p);
            positions.push(rest[bone].translation + world * local);
            normals.push((world * in_bone * Vec3::from(*m)).normalize_or(Vec3::Y));
            joints.push(bone as u16);
        }
        match mesh.indices() {
            Some(Indices::U16(i)) => indices.extend(i.iter().map(|&i| first + i as u32)),
            Some(Indices::U32(i)) => indices.extend(i.iter().map(|&i| first + i)),
            None => {}
        }
    }
    let (lo, hi) = positions.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let count = positions.len();
    let position = file.accessor(
        &flat(positions.iter().map(|p| p.to_array())),
        Some(34962),
        FLOAT,
        count,
        "VEC3",
        Some((lo.to_array().to_vec(), hi.to_array().to_vec())),
    );
    let normal = file.accessor(
        &flat(normals.iter().map(|p| p.to_array())),
        Some(34962),
        FLOAT,
        count,
        "VEC3",
        None,
    );
    let joint_bytes: Vec<u8> = joints
        .iter()
        .flat_map(|&j| [j, 0, 0, 0])
        .flat_map(u16::to_le_bytes)
        .collect();
    let joint = file.accessor(
        &joint_bytes,
        Some(34962),
        UNSIGNED_SHORT,
        count,
        "VEC4",
        None,
    );
    let weight = file.accessor(
        &flat((0..count).map(|_| [1.0f32, 0.0, 0.0, 0.0])),
        Some(34962),
        FLOAT,
        count,
        "VEC4",
        None,
    );
    let index_bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    let index = file.accessor(
        &index_bytes,
        Some(34963),
        UNSIGNED_INT,
        indices.len(),
        "SCALAR",
        None,
    );
    let inverse_binds = file.accessor(
        &flat(rest.iter().map(|b| {
            Mat4::from_rotation_translation(b.rotation, b.translation)
                .inverse()
                .to_cols_array()
        })),
        None,
        FLOAT,
        n,
        "MAT4",
        None,
    );

    let animations: Vec<Value> = clips
        .iter()
        .map(|(name, clip)| file.animation(name, clip, rig, hz))
        .collect();

    let document = json!({
        "asset": { "version": "2.0", "generator": "bevy_drape generate_character" },
        "scene": 0,
        "scenes": [{ "name": "humanoid", "nodes": [0] }],
        "nodes": nodes,
        "meshes": [{
            "name": "body",
            "primitives": [{
                "attributes": {
                    "POSITION": position,
                    "NORMAL": normal,
                    "JOINTS_0": joint,
                    "WEIGHTS_0": weight,
                },
                "indices": index,
                "material": 0,
            }],
        }],
        "materials": [{
            "name": "skin",
            "pbrMetallicRoughness": {
                "baseColorFactor": [0.80, 0.62, 0.50, 1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": 0.8,
            },
        }],
        "skins": [{ "joints": (1..=n).collect::<Vec<_>>(), "skeleton": 1, "inverseBindMatrices": inverse_binds }],
        "animations": animations,
    });
    file.finish(document)
}

const FLOAT: u32 = 5126;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_INT: u32 = 5125;

/// Bone `b`'s transform in its parent's frame, from world (character-frame) states.
fn local_transform(states: &[BoneState], rig: &Rig, b: usize) -> (Vec3, Quat) {
    let state = states[b];
    match rig.bones()[b].parent {
        None => (state.translation, state.rotation),
        Some(p) => {
            let parent = states[p];
            let inverse = parent.rotation.inverse();
            (
                inverse * (state.translation - parent.translation),
                (inverse * state.rotation).normalize(),
            )
        }
    }
}

fn flat<const N: usize>(items: impl Iterator<Item = [f32; N]>) -> Vec<u8> {
    items.flatten().flat_map(f32::to_le_bytes).collect()
}

/// The binary chunk, its views and accessors as they are added.
#[derive(Default)]
struct GlbBuilder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl GlbBuilder {
    /// Adds `bytes` as a buffer view and an accessor over it; returns the accessor's index.
    fn accessor(
        &mut self,
        bytes: &[u8],
        target: Option<u32>,
        component: u32,
        count: usize,
        kind: &str,
        bounds: Option<(Vec<f32>, Vec<f32>)>,
    ) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut view = json!({
            "buffer": 0,
            "byteOffset": self.bin.len(),
            "byteLength": bytes.len(),
        });
        if let Some(target) = target {
            view["target"] = json!(target);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(view);
        let mut accessor = json!({
            "bufferView": self.views.len() - 1,
            "componentType": component,
            "count": count,
            "type": kind,
        });
        if let Some((min, max)) = bounds {
            accessor["min"] = json!(min);
            accessor["max"] = json!(max);
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    /// `clip` sampled at `hz` over its duration: the root's translation and rotation and every
    /// other bone's rotation.
    fn animation(&mut self, name: &str, clip: &Clip, rig: &Rig, hz: f32) -> Value {
        let steps = (clip.duration() * hz).ceil().max(1.0) as usize;
        let times: Vec<f32> = (0..=steps)
            .map(|k| clip.duration() * k as f32 / steps as f32)
            .collect();
        let mut pose = Pose {
            angles: vec![0.0; rig.bones().len()],
            ..Pose::default()
        };
        let mut rate = PoseRate::default();
        let mut states = Vec::new();
        let n = rig.bones().len();
        let mut rotations = vec![Vec::with_capacity(times.len()); n];
        let mut root_translations = Vec::with_capacity(times.len());
        for &t in &times {
            clip.sample(t, &mut pose, &mut rate);
            rig.forward(&pose, None, &mut states);
            for (b, track) in rotations.iter_mut().enumerate() {
                let (translation, rotation) = local_transform(&states, rig, b);
                // Keep consecutive samples in one hemisphere so interpolation takes the short way.
                let rotation = match track.last() {
                    Some(last) if rotation.dot(*last) < 0.0 => -rotation,
                    _ => rotation,
                };
                track.push(rotation);
                if b == 0 {
                    root_translations.push(translation);
                }
            }
        }
        let input = self.accessor(
            &flat(times.iter().map(|&t| [t])),
            None,
            FLOAT,
            times.len(),
            "SCALAR",
            Some((vec![times[0]], vec![*times.last().unwrap_or(&0.0)])),
        );
        let mut samplers = Vec::new();
        let mut channels = Vec::new();
        let mut channel = |this: &mut Self, node: usize, path: &str, bytes: Vec<u8>, kind: &str| {
            let output = this.accessor(&bytes, None, FLOAT, times.len(), kind, None);
            samplers.push(json!({ "input": input, "output": output, "interpolation": "LINEAR" }));
            channels.push(json!({
                "sampler": samplers.len() - 1,
                "target": { "node": node, "path": path },
            }));
        };
        channel(
            self,
            1,
            "translation",
            flat(root_translations.iter().map(|t| t.to_array())),
            "VEC3",
        );
        for (b, track) in rotations.iter().enumerate() {
            channel(
                self,
                b + 1,
                "rotation",
                flat(track.iter().map(|q| q.to_array())),
                "VEC4",
            );
        }
        json!({ "name": name, "samplers": samplers, "channels": channels })
    }

    /// The `.glb` file: header, JSON chunk (padded with spaces), binary chunk (padded with
    /// zeros).
    fn finish(mut self, mut document: Value) -> Vec<u8> {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        document["buffers"] = json!([{ "byteLength": self.bin.len() }]);
        document["bufferViews"] = json!(self.views);
        document["accessors"] = json!(self.accessors);
        let mut text = serde_json::to_vec(&document).expect("a JSON value serialises");
        while !text.len().is_multiple_of(4) {
            text.push(b' ');
        }
        let total = 12 + 8 + text.len() + 8 + self.bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(text.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&text);
        out.extend_from_slice(&(self.bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&self.bin);
        out
    }
}
