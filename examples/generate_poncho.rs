//! Writes the poncho pattern ([`bevy_drape::cloth::PonchoDesc`]) as a Wavefront OBJ.
//!
//! ```text
//! cargo run --example generate_poncho -- [--vertices 41] [--size 1.3] [--neck-radius 0.13] [--out assets/meshes/poncho.obj]
//! ```
//!
//! The defaults write the `assets/meshes/poncho.obj` the poncho example loads.

use bevy_drape::cloth::{PonchoDesc, to_obj};

fn main() {
    if let Err(message) = run() {
        eprintln!("generate_poncho: {message}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), String> {
    let mut desc = PonchoDesc::default();
    let mut out = "assets/meshes/poncho.obj".to_string();
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        let mut value = || args.next().ok_or(format!("{flag} needs a value"));
        match flag.as_str() {
            "--vertices" => desc.vertices = parse(&value()?)?,
            "--size" => desc.size = parse(&value()?)?,
            "--neck-radius" => desc.neck_radius = parse(&value()?)?,
            "--out" => out = value()?,
            other => return Err(format!("unknown option {other}")),
        }
    }
    let mesh = desc.mesh().map_err(|e| e.to_string())?;
    let header = format!(
        "# poncho: {} m square, {} vertices per side, neck hole radius {} m\n# written by `cargo run --example generate_poncho`\n",
        desc.size, desc.vertices, desc.neck_radius
    );
    std::fs::write(&out, header + &to_obj(&mesh, "poncho")).map_err(|e| format!("{out}: {e}"))?;
    println!(
        "wrote {out}: {} vertices, {} triangles",
        mesh.positions.len(),
        mesh.indices.len() / 3
    );
    Ok(())
}

fn parse<T: std::str::FromStr>(s: &str) -> Result<T, String> {
    s.parse().map_err(|_| format!("cannot parse {s:?}"))
}
