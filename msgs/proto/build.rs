//! Compiles `proto/polarnav/polarnav.proto` with protox (a protobuf compiler
//! in Rust: no `protoc` to install) into a FileDescriptorSet, which prost
//! turns into Rust types and which MCAP files and the Foxglove view carry
//! as each channel's schema.

use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let proto = "proto/polarnav/polarnav.proto";
    println!("cargo:rerun-if-changed={proto}");
    let fds = protox::compile([proto], ["proto"])?;
    let out = PathBuf::from(std::env::var("OUT_DIR")?);
    std::fs::write(
        out.join("polarnav.fds"),
        prost::Message::encode_to_vec(&fds),
    )?;
    prost_build::Config::new().compile_fds(fds)?;
    Ok(())
}
