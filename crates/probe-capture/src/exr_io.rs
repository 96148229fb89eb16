//! Plain f32 EXR layers with named channels, through the `exr` crate.

use std::path::Path;

use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image, ImageAttributes, IntegerBounds, Layer,
    LayerAttributes, ReadChannels, ReadLayers, SmallVec, Text, Vec2, WritableImage,
};

/// One layer of an EXR file: a `width × height` image (row-major from the top-left) with
/// named f32 channels.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ExrLayer {
    pub name: String,
    pub width: usize,
    pub height: usize,
    pub channels: Vec<(String, Vec<f32>)>,
}

/// Lossless compression for every file written (ZIP, 16 scan lines a block).
const ENCODING: Encoding = Encoding::SMALL_LOSSLESS;

/// Writes the layers (each channel holds `width × height` samples) as f32 to `path`.
pub(crate) fn write(path: &Path, layers: Vec<ExrLayer>) -> Result<(), exr::error::Error> {
    let (mut width, mut height) = (1, 1);
    let layers: Vec<Layer<AnyChannels<FlatSamples>>> = layers
        .into_iter()
        .map(|layer| {
            width = width.max(layer.width);
            height = height.max(layer.height);
            let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = layer
                .channels
                .into_iter()
                .map(|(name, samples)| AnyChannel::new(name.as_str(), FlatSamples::F32(samples)))
                .collect();
            Layer::new(
                (layer.width, layer.height),
                LayerAttributes::named(layer.name.as_str()),
                ENCODING,
                AnyChannels::sort(channels),
            )
        })
        .collect();
    let attributes = ImageAttributes::new(IntegerBounds::from_dimensions(Vec2(width, height)));
    let image = Image::from_layers(attributes, layers);
    image.write().to_file(path)
}

/// Reads every layer of an EXR file (pedantic: damaged files are errors). Channels stored as
/// f16 or u32 come back converted to f32 but flagged in `converted`.
pub(crate) fn read(path: &Path) -> Result<Vec<ExrRead>, exr::error::Error> {
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .pedantic()
        .from_file(path)?;
    Ok(image
        .layer_data
        .into_iter()
        .map(|layer| ExrRead {
            name: layer
                .attributes
                .layer_name
                .as_ref()
                .map(Text::to_string)
                .unwrap_or_default(),
            width: layer.size.0,
            height: layer.size.1,
            channels: layer
                .channel_data
                .list
                .into_iter()
                .map(|channel| {
                    let name = channel.name.to_string();
                    match channel.sample_data {
                        FlatSamples::F32(samples) => (name, samples, false),
                        other => (name, other.values_as_f32().collect(), true),
                    }
                })
                .collect(),
        })
        .collect())
}

/// A layer read back: as [`ExrLayer`], with a flag per channel telling whether the samples
/// were not stored as f32.
#[derive(Clone, Debug)]
pub(crate) struct ExrRead {
    pub name: String,
    pub width: usize,
    pub height: usize,
    pub channels: Vec<(String, Vec<f32>, bool)>,
}
