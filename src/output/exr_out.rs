//! Linear OpenEXR output: the beauty image as R, G, B, A plus AOV channels
//! `albedo.{R,G,B}`, `normal.{X,Y,Z}`, `depth.Z`, `direct.{R,G,B}` (and later passes add
//! their own). 32-bit float, ZIP compression of single scan lines, compressed on every core and
//! written in line order, so the bytes are deterministic.

use super::write_atomically;
use crate::frame::Frame;
use crate::scene::limits::{MAX_IMAGE_SAMPLES, check_image_size, file_len};
use crate::{Error, Result};
use exr::prelude::*;
use std::path::Path;

/// Named channels of an EXR file, each `width * height` floats, top row first.
pub type Channels = Vec<(String, Vec<f32>)>;

/// All channels of a frame, in the order they are written (gathered on every core: 17
/// passes over a million pixels at 1000x1000).
pub fn frame_channels(frame: &Frame) -> Channels {
    type Gather<'a> = Box<dyn Fn() -> Vec<f32> + Sync + 'a>;
    fn component(img: &[[f32; 4]], c: usize) -> Gather<'_> {
        Box::new(move || img.iter().map(|p| p[c]).collect())
    }
    let mut list: Vec<(&str, Gather)> = vec![
        ("R", component(&frame.beauty, 0)),
        ("G", component(&frame.beauty, 1)),
        ("B", component(&frame.beauty, 2)),
        ("A", component(&frame.beauty, 3)),
        ("albedo.R", component(&frame.albedo, 0)),
        ("albedo.G", component(&frame.albedo, 1)),
        ("albedo.B", component(&frame.albedo, 2)),
    ];
    for (c, name) in ["normal.X", "normal.Y", "normal.Z"].into_iter().enumerate() {
        list.push((
            name,
            Box::new(move || {
                let normal = |v: &crate::visibility::VisSample| match v.is_hit() {
                    true => v.shading_normal[c],
                    false => 0.0,
                };
                frame.visibility.iter().map(normal).collect()
            }),
        ));
    }
    list.push(("depth.Z", Box::new(|| frame.depth())));
    for (c, name) in ["direct.R", "direct.G", "direct.B"].into_iter().enumerate() {
        list.push((name, component(&frame.direct, c)));
    }
    if let Some(indirect) = &frame.indirect {
        for (c, name) in ["indirect.R", "indirect.G", "indirect.B"]
            .into_iter()
            .enumerate()
        {
            list.push((name, component(indirect, c)));
        }
    }
    let data = crate::parallel::ordered_map(list.len(), |i| (list[i].1)());
    list.iter()
        .zip(data)
        .map(|((name, _), d)| (name.to_string(), d))
        .collect()
}

/// Encodes channels as EXR bytes (a copy of them; [`encode_exr_owned`] takes them).
pub fn encode_exr(
    width: u32,
    height: u32,
    channels: &Channels,
) -> std::result::Result<Vec<u8>, String> {
    encode_exr_owned(width, height, channels.clone())
}

/// Encodes channels as EXR bytes, consuming them (no copy of a frame's 17 channels).
///
/// ZIP compression of single scan lines (OpenEXR's ZIPS): on Sponza's 1000x1000 frame (17
/// channels) 2.3x faster to encode on one core than ZIP of 16-line blocks, for files 2 %
/// larger (docs/results.md, "Where a frame's wall time goes"); the lines are compressed on
/// every core ([`crate::parallel::ordered_map`]: the same bytes on any number).
pub fn encode_exr_owned(
    width: u32,
    height: u32,
    channels: Channels,
) -> std::result::Result<Vec<u8>, String> {
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = channels
        .into_iter()
        .map(|(name, data)| AnyChannel::new(name.as_str(), FlatSamples::F32(data)))
        .collect();
    let encoding = Encoding {
        compression: Compression::ZIP1,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    let layer = Layer::new(
        (width as usize, height as usize),
        LayerAttributes::default(),
        encoding,
        AnyChannels::sort(list),
    );
    use exr::block::chunk::{Chunk, CompressedBlock, CompressedScanLineBlock};
    use exr::block::writer::ChunksWriter;
    use exr::image::write::layers::WritableLayers;
    let image = Image::from_layer(layer);
    // What `image.write().to_buffered(..)` would write as headers.
    let headers = image.layer_data.infer_headers(&image.attributes);
    // The crate's writer gathers each line for its compressors on one thread, sample by
    // sample, and deflates at level 4. Here every core builds and compresses its lines
    // (rows of each channel in the header's order, little-endian), written in line order.
    let samples: Vec<&[f32]> = image
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| match &c.sample_data {
            FlatSamples::F32(v) => Ok(v.as_slice()),
            _ => Err("internal: EXR channels must be 32-bit float".to_string()),
        })
        .collect::<std::result::Result<_, _>>()?;
    let row = width as usize;
    let mut bytes = std::io::Cursor::new(Vec::new());
    exr::block::write(&mut bytes, headers, true, |meta, writer| {
        let blocks: Vec<(usize, exr::block::BlockIndex)> =
            meta.enumerate_ordered_header_block_indices().collect();
        let chunks = crate::parallel::ordered_map(blocks.len(), |i| {
            let index = blocks[i].1;
            let (x, y) = (index.pixel_position.x(), index.pixel_position.y());
            let (w, h) = (index.pixel_size.width(), index.pixel_size.height());
            let mut data = Vec::with_capacity(w * h * samples.len() * 4);
            for line in y..y + h {
                for channel in &samples {
                    let start = line * row + x;
                    for v in &channel[start..start + w] {
                        data.extend_from_slice(&v.to_le_bytes());
                    }
                }
            }
            Chunk {
                layer_index: 0,
                compressed_block: CompressedBlock::ScanLine(CompressedScanLineBlock {
                    y_coordinate: y as i32,
                    compressed_pixels_le: zip_block(data),
                }),
            }
        });
        for ((index_in_header, _), chunk) in blocks.iter().zip(chunks) {
            writer.write_chunk(*index_in_header, chunk)?;
        }
        Ok(())
    })
    .map_err(|e| e.to_string())?;
    Ok(bytes.into_inner())
}

/// OpenEXR's ZIP compression of one block of little-endian samples: the bytes split into
/// the even- and the odd-numbered halves, each byte replaced by its difference to the one
/// before (plus 128), then zlib. Deflate level 1: on Sponza's 17 channels 2.8x faster than
/// the exr crate's level 4 on one core (0.20 against 0.54 s) for 5 % more bytes (23 against
/// 22 MB). A block that does not shrink is stored as it is, as OpenEXR readers expect.
fn zip_block(le: Vec<u8>) -> Vec<u8> {
    let n = le.len();
    let half = n.div_ceil(2);
    let mut split = vec![0u8; n];
    for (i, b) in le.iter().enumerate() {
        split[if i % 2 == 0 { i / 2 } else { half + i / 2 }] = *b;
    }
    let mut previous = split.first().copied().unwrap_or(0);
    for b in split.iter_mut().skip(1) {
        let current = *b;
        *b = current.wrapping_sub(previous).wrapping_add(128);
        previous = current;
    }
    let compressed = miniz_oxide::deflate::compress_to_vec_zlib(&split, 1);
    if compressed.len() < n { compressed } else { le }
}

/// Writes a frame with all its AOVs to `path`, atomically. Returns the bytes written.
pub fn write_exr(path: &Path, frame: &Frame) -> Result<Vec<u8>> {
    let bytes =
        encode_exr_owned(frame.width, frame.height, frame_channels(frame)).map_err(|message| {
            Error::Output {
                path: path.to_path_buf(),
                message,
            }
        })?;
    write_atomically(path, &bytes)?;
    Ok(bytes)
}

/// Reads every channel of the first layer of an EXR file: (width, height, channels).
///
/// The headers are read and checked first ([`check_exr_headers`]), so that a file whose
/// header claims more pixels than the file can hold, or than [`crate::scene::limits::MAX_IMAGE_PIXELS`], is
/// refused before the decoder allocates its sample buffers from that claim.
pub fn read_exr_channels(path: &Path) -> Result<(u32, u32, Channels)> {
    check_exr_headers(path)?;
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

/// Checks the size every header of the EXR file at `path` claims against the file's length
/// and the caps of [`crate::scene::limits`], before any pixel is read.
///
/// The least a layer needs in the file: one 8-byte offset-table entry and one chunk header
/// of at least 8 bytes (its y or tile coordinates and its data size) per chunk, and, for
/// the encodings whose best compression ratio is bounded, that fraction of the raw pixel
/// bytes: all of them uncompressed, 1/64 for RLE (a run of up to 128 bytes costs 2), 1/1032
/// for ZIP (deflate's limit). The other encodings are only held to the chunk count.
pub fn check_exr_headers(path: &Path) -> Result<()> {
    let bytes = file_len(path)?;
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| match e {
        exr::error::Error::Io(source) => Error::Io {
            path: path.to_path_buf(),
            source,
        },
        other => Error::invalid(path, "header", other.to_string()),
    })?;
    let mut needed = 0u64;
    for (layer, header) in meta.headers.iter().enumerate() {
        let (w, h) = (header.layer_size.0 as u64, header.layer_size.1 as u64);
        let (mut samples, mut raw) = (0u64, 0u64);
        for channel in &header.channels.list {
            let (sx, sy) = (channel.sampling.0.max(1), channel.sampling.1.max(1));
            let count = (w / sx as u64).saturating_mul(h / sy as u64);
            samples = samples.saturating_add(count);
            let size = channel.sample_type.bytes_per_sample() as u64;
            raw = raw.saturating_add(count.saturating_mul(size));
        }
        let compressed = match header.compression {
            Compression::Uncompressed => raw,
            Compression::RLE => raw / 64,
            Compression::ZIP1 | Compression::ZIP16 => raw / 1032,
            _ => 0,
        };
        let chunks = (header.chunk_count as u64).saturating_mul(16);
        needed = needed.saturating_add(chunks.max(compressed));
        let format = if meta.headers.len() > 1 {
            format!("OpenEXR layer {layer}")
        } else {
            "OpenEXR".to_string()
        };
        check_image_size(path, &format, (w, h), needed, bytes)?;
        if samples > MAX_IMAGE_SAMPLES {
            return Err(Error::invalid(
                path,
                "header",
                format!(
                    "{format}: the header claims {w}x{h} pixels in {} channels ({samples} \
                     values); at most {MAX_IMAGE_SAMPLES} are accepted",
                    header.channels.list.len()
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What a user reads back is bit for bit what was rendered: the encoding is lossless for
    /// every f32 value a frame holds (signed zeros, subnormals, +inf depth on background),
    /// and the channels keep their names.
    #[test]
    fn exr_round_trip_is_bit_exact() {
        let (w, h) = (37u32, 23u32);
        let mut state = 0x2545_f491u32;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        };
        let specials = [
            0.0f32,
            -0.0,
            f32::MIN_POSITIVE / 4.0,
            f32::INFINITY,
            1.0e30,
            -3.5,
        ];
        let channels: Channels = ["R", "G", "B", "depth.Z", "indirect.R"]
            .iter()
            .map(|name| {
                let data = (0..w * h)
                    .map(|i| {
                        if i % 7 == 0 {
                            specials[(i / 7) as usize % specials.len()]
                        } else {
                            // Finite values of every exponent (no NaN: frames refuse them).
                            let bits = next() & 0xbf7f_ffff;
                            f32::from_bits(bits)
                        }
                    })
                    .collect();
                (name.to_string(), data)
            })
            .collect();
        let bytes = encode_exr(w, h, &channels).expect("encode");
        let dir = std::env::temp_dir().join(format!("radsplat-exr-rt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("rt.exr");
        std::fs::write(&path, &bytes).expect("write");
        let (rw, rh, back) = read_exr_channels(&path).expect("read back");
        std::fs::remove_dir_all(&dir).ok();
        assert_eq!((rw, rh), (w, h));
        assert_eq!(back.len(), channels.len());
        for (name, data) in &channels {
            let (_, got) = back.iter().find(|(n, _)| n == name).expect("channel kept");
            let same = data
                .iter()
                .zip(got)
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "channel {name} changed in the round trip");
        }
        // Same bytes from the owned encoder (what `render` writes).
        assert_eq!(bytes, encode_exr_owned(w, h, channels).expect("encode"));
    }
}
