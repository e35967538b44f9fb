//! The mesh drop: a small sheet dropped over a triangle-mesh collider read from an OBJ file (a
//! scanned model, a low-poly one), and how far its edges stretch and how deep it goes.

use std::sync::Arc;
use std::time::Instant;

use bevy::math::Vec3;
use bevy_drape::cloth::{ClothModel, ClothSolver, GridDesc, SolverSettings};
use bevy_drape::collide::{ContactMaterial, RigidPose, SolverCollider, SolverShape, TriMesh};

use super::common::{DENSITY, FRAME_RATE, GRAVITY};

/// The mesh drop: an `n` x `n` sheet, 1 m square, flat, [`MeshDrop::DROP_HEIGHT`] above the
/// top of a triangle mesh scaled to [`MeshDrop::SIZE`] across (its longest horizontal side)
/// standing on the ground, turned by `yaw` about the vertical, the sheet's centre `offset`
/// from the mesh's; the mesh and the ground have friction [`MeshDrop::FRICTION`] and margin
/// [`MeshDrop::MARGIN`].
#[derive(Clone, Debug)]
pub struct MeshDrop {
    /// Vertices per side of the sheet.
    pub n: u32,
    /// The collider, scaled and placed.
    pub mesh: Arc<TriMesh>,
    /// The collider's vertices, scaled and placed, as read (the collider welds them).
    pub vertices: Vec<Vec3>,
    /// The collider's triangles, three indices into `vertices` each.
    pub indices: Vec<u32>,
    /// The mesh's top, m above the ground.
    pub top: f32,
    /// The sheet's centre, horizontally from the mesh's, m.
    pub offset: Vec3,
}

impl MeshDrop {
    /// The mesh's longest horizontal side, m.
    pub const SIZE: f32 = 0.6;
    /// Height of the sheet above the mesh's top at the start, m.
    pub const DROP_HEIGHT: f32 = 0.1;
    /// Friction of the mesh and the ground.
    pub const FRICTION: f32 = 0.5;
    /// Margin of the mesh and the ground, m.
    pub const MARGIN: f32 = 0.005;

    /// The scene for the mesh in `obj` (the text of an OBJ file: its `v` and `f` lines, faces
    /// of any size fanned into triangles, see [`read_obj`]) turned by `yaw` radians about the
    /// vertical, scaled to [`MeshDrop::SIZE`] and put on the ground under the sheet's centre.
    pub fn from_obj(n: u32, obj: &str, yaw: f32) -> Result<Self, String> {
        let (vertices, indices) = read_obj(obj)?;
        let turn = bevy::math::Quat::from_rotation_y(yaw);
        let vertices: Vec<Vec3> = vertices.iter().map(|&v| turn * v).collect();
        let (mut min, mut max) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        for &v in &vertices {
            min = min.min(v);
            max = max.max(v);
        }
        let extent = (max - min).x.max((max - min).z);
        if extent.is_nan() || extent <= 0.0 {
            return Err("the mesh has no horizontal extent".into());
        }
        let scale = Self::SIZE / extent;
        let centre = Vec3::new(0.5 * (min.x + max.x), min.y, 0.5 * (min.z + max.z));
        let placed: Vec<Vec3> = vertices.iter().map(|&v| (v - centre) * scale).collect();
        let mesh = TriMesh::new(&placed, &indices).map_err(|e| e.to_string())?;
        Ok(Self {
            n,
            mesh: Arc::new(mesh),
            vertices: placed,
            indices,
            top: (max.y - min.y) * scale,
            offset: Vec3::ZERO,
        })
    }

    /// The mesh and the ground.
    pub fn colliders(&self) -> [SolverCollider; 2] {
        let material = ContactMaterial {
            friction: Self::FRICTION,
            restitution: 0.0,
        };
        let mut mesh = SolverCollider::fixed(
            SolverShape::TriangleMesh(self.mesh.clone()),
            RigidPose::IDENTITY,
        );
        mesh.material = material;
        mesh.margin = Self::MARGIN;
        let mut ground = SolverCollider::fixed(SolverShape::Plane, RigidPose::IDENTITY);
        ground.material = material;
        ground.margin = Self::MARGIN;
        [mesh, ground]
    }

    /// The sheet at rest above the mesh, with the colliders set.
    pub fn build(&self) -> Result<ClothSolver, String> {
        let origin = Vec3::new(-0.5, self.top + Self::DROP_HEIGHT, -0.5) + self.offset;
        let model = ClothModel::grid(&GridDesc::square(1.0, self.n, origin), DENSITY)
            .map_err(|e| e.to_string())?;
        let mut sim = ClothSolver::new(model);
        sim.set_colliders(&self.colliders())
            .map_err(|e| e.to_string())?;
        Ok(sim)
    }

    /// Runs `frames` frames at [`FRAME_RATE`].
    pub fn run(&self, settings: &SolverSettings, frames: u32) -> Result<MeshDropRun, String> {
        let mut sim = self.build()?;
        let dt = 1.0 / FRAME_RATE;
        let mut run = MeshDropRun {
            frame_seconds: Vec::with_capacity(frames as usize),
            largest_strain: 0.0,
            deepest: 0.0,
            finite: true,
            max_strain: 0.0,
            sim: sim.clone(),
        };
        let shape = SolverShape::TriangleMesh(self.mesh.clone());
        for frame in 1..=frames {
            let start = Instant::now();
            sim.step(settings, GRAVITY, dt).map_err(|e| e.to_string())?;
            run.frame_seconds.push(start.elapsed().as_secs_f64());
            run.finite &= sim.is_finite();
            if frame as f32 > FRAME_RATE {
                run.largest_strain = run.largest_strain.max(sim.strain().max);
            }
            for &p in &sim.state().positions {
                if let Some((d, _)) = shape.signed_distance(p, Self::MARGIN) {
                    run.deepest = run.deepest.max(-d);
                }
            }
        }
        run.max_strain = sim.strain().max;
        run.sim = sim;
        Ok(run)
    }
}

/// The outcome of one mesh-drop run.
#[derive(Clone, Debug)]
pub struct MeshDropRun {
    /// Wall time of every frame, s.
    pub frame_seconds: Vec<f64>,
    /// Largest structural strain after any frame after the first second.
    pub largest_strain: f32,
    /// Largest strain at the end.
    pub max_strain: f32,
    /// The deepest any particle was inside the mesh after any frame, m (0 for an open mesh,
    /// which has no inside).
    pub deepest: f32,
    /// Whether every position stayed finite.
    pub finite: bool,
    /// The cloth at the end.
    pub sim: ClothSolver,
}

/// The vertices and triangles of an OBJ file's text: its `v` lines (the first three numbers)
/// and its `f` lines (the vertex index before any `/`, 1-based or negative from the end),
/// polygons fanned into triangles; every other line ignored.
pub fn read_obj(text: &str) -> Result<(Vec<Vec3>, Vec<u32>), String> {
    let mut vertices = Vec::new();
    let mut indices = Vec::new();
    for (line_number, line) in text.lines().enumerate() {
        let bad = |what: &str| format!("line {}: {what}", line_number + 1);
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let mut xyz = [0.0f32; 3];
                for c in &mut xyz {
                    *c = words
                        .next()
                        .and_then(|w| w.parse().ok())
                        .ok_or_else(|| bad("a vertex needs three numbers"))?;
                }
                vertices.push(Vec3::from_array(xyz));
            }
            Some("f") => {
                let corners = words
                    .map(|w| {
                        let index: i64 = w
                            .split('/')
                            .next()
                            .and_then(|i| i.parse().ok())
                            .ok_or_else(|| bad("a face corner needs a vertex index"))?;
                        let count = vertices.len() as i64;
                        let index = if index < 0 { count + index } else { index - 1 };
                        u32::try_from(index)
                            .ok()
                            .filter(|&i| (i as i64) < count)
                            .ok_or_else(|| bad("a face names a vertex not read yet"))
                    })
                    .collect::<Result<Vec<u32>, String>>()?;
                for k in 1..corners.len().saturating_sub(1) {
                    indices.extend_from_slice(&[corners[0], corners[k], corners[k + 1]]);
                }
            }
            _ => {}
        }
    }
    Ok((vertices, indices))
}
