//! Writes the humanoid (its rig, a body skinned to it and the walk and wave clips) as a glTF
//! binary, the character the `gltf_character` example loads like any other model.
//!
//! ```text
//! cargo run --example generate_character -- [--out assets/characters/humanoid.glb]
//! ```

fn main() {
    let mut out = "assets/characters/humanoid.glb".to_string();
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        match (flag.as_str(), args.next()) {
            ("--out", Some(path)) => out = path,
            _ => {
                eprintln!("generate_character: usage: generate_character [--out FILE.glb]");
                std::process::exit(2);
            }
        }
    }
    let bytes = drape_scenes::gltf_export::humanoid_glb();
    if let Err(e) = std::fs::write(&out, &bytes) {
        eprintln!("generate_character: {out}: {e}");
        std::process::exit(2);
    }
    println!("wrote {out}: {} bytes", bytes.len());
}
