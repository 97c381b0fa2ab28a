//! Linear OpenEXR output: the beauty image as R, G, B, A plus AOV channels
//! `albedo.{R,G,B}`, `normal.{X,Y,Z}`, `depth.Z`, `direct.{R,G,B}` (and later passes add
//! their own). 32-bit float, ZIP compression, written single-threaded so the bytes are
//! deterministic.

use super::write_atomically;
use crate::frame::Frame;
use crate::{Error, Result};
use exr::prelude::*;
use std::path::Path;

/// Named channels of an EXR file, each `width * height` floats, top row first.
pub type Channels = Vec<(String, Vec<f32>)>;

/// All channels of a frame, in the order they are written.
pub fn frame_channels(frame: &Frame) -> Channels {
    let split4 = |img: &[[f32; 4]], names: [&str; 3]| -> Vec<(String, Vec<f32>)> {
        (0..3)
            .map(|c| (names[c].to_string(), img.iter().map(|p| p[c]).collect()))
            .collect()
    };
    let mut ch = split4(&frame.beauty, ["R", "G", "B"]);
    ch.push(("A".into(), frame.beauty.iter().map(|p| p[3]).collect()));
    ch.extend(split4(&frame.albedo, ["albedo.R", "albedo.G", "albedo.B"]));
    let normals = frame.normals();
    for (c, name) in ["normal.X", "normal.Y", "normal.Z"].iter().enumerate() {
        ch.push((name.to_string(), normals.iter().map(|n| n[c]).collect()));
    }
    ch.push(("depth.Z".into(), frame.depth()));
    ch.extend(split4(&frame.direct, ["direct.R", "direct.G", "direct.B"]));
    if let Some(indirect) = &frame.indirect {
        ch.extend(split4(indirect, ["indirect.R", "indirect.G", "indirect.B"]));
    }
    ch
}

/// Encodes channels as EXR bytes.
pub fn encode_exr(
    width: u32,
    height: u32,
    channels: &Channels,
) -> std::result::Result<Vec<u8>, String> {
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = channels
        .iter()
        .map(|(name, data)| AnyChannel::new(name.as_str(), FlatSamples::F32(data.clone())))
        .collect();
    let layer = Layer::new(
        (width as usize, height as usize),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .non_parallel()
        .to_buffered(&mut bytes)
        .map_err(|e| e.to_string())?;
    Ok(bytes.into_inner())
}

/// Writes a frame with all its AOVs to `path`, atomically. Returns the bytes written.
pub fn write_exr(path: &Path, frame: &Frame) -> Result<Vec<u8>> {
    let bytes =
        encode_exr(frame.width, frame.height, &frame_channels(frame)).map_err(|message| {
            Error::Output {
                path: path.to_path_buf(),
                message,
            }
        })?;
    write_atomically(path, &bytes)?;
    Ok(bytes)
}

/// Reads every channel of the first layer of an EXR file: (width, height, channels).
pub fn read_exr_channels(path: &Path) -> Result<(u32, u32, Channels)> {
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| match e {
            exr::error::Error::Io(source) => Error::Io {
                path: path.to_path_buf(),
                source,
            },
            other => Error::invalid(path, "header", other.to_string()),
        })?;
    let size = image.layer_data.size;
    let channels = image
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    Ok((size.0 as u32, size.1 as u32, channels))
}
