//! Bounds-checked reading of glTF accessors (dense and sparse) into `f32` or `u32` values.
//!
//! The `gltf` crate's own readers assume valid offsets and may panic on malformed files; these
//! check every range and report the accessor by index.

use gltf::accessor::{DataType, Dimensions};

/// A problem with one accessor, turned into a `LoadError::BadAccessor` by the caller.
pub(crate) struct AccessorProblem {
    pub accessor: usize,
    pub name: String,
    pub reason: String,
}

fn problem(accessor: &gltf::Accessor<'_>, reason: impl Into<String>) -> AccessorProblem {
    AccessorProblem {
        accessor: accessor.index(),
        name: accessor.name().unwrap_or_default().to_owned(),
        reason: reason.into(),
    }
}

pub(crate) fn component_count(dimensions: Dimensions) -> usize {
    match dimensions {
        Dimensions::Scalar => 1,
        Dimensions::Vec2 => 2,
        Dimensions::Vec3 => 3,
        Dimensions::Vec4 => 4,
        Dimensions::Mat2 => 4,
        Dimensions::Mat3 => 9,
        Dimensions::Mat4 => 16,
    }
}

fn component_size(data_type: DataType) -> usize {
    match data_type {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

/// One component at `bytes[0..size]` as `f32`, applying the glTF normalisation rules.
#[inline]
fn read_component(bytes: &[u8], data_type: DataType, normalized: bool) -> f32 {
    match data_type {
        DataType::F32 => f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]),
        DataType::U8 => {
            let v = f32::from(bytes[0]);
            if normalized { v / 255.0 } else { v }
        }
        DataType::I8 => {
            let v = f32::from(bytes[0] as i8);
            if normalized { (v / 127.0).max(-1.0) } else { v }
        }
        DataType::U16 => {
            let v = f32::from(u16::from_le_bytes([bytes[0], bytes[1]]));
            if normalized { v / 65535.0 } else { v }
        }
        DataType::I16 => {
            let v = f32::from(i16::from_le_bytes([bytes[0], bytes[1]]));
            if normalized {
                (v / 32767.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U32 => {
            let v = u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f32;
            if normalized { v / 4_294_967_295.0 } else { v }
        }
    }
}

#[inline]
fn read_index(bytes: &[u8], data_type: DataType) -> Option<u32> {
    match data_type {
        DataType::U8 => Some(u32::from(bytes[0])),
        DataType::U16 => Some(u32::from(u16::from_le_bytes([bytes[0], bytes[1]]))),
        DataType::U32 => Some(u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]])),
        _ => None,
    }
}

/// The bytes of a buffer view, checked against the buffer's data.
fn view_bytes<'b>(
    view: &gltf::buffer::View<'_>,
    buffers: &'b [Vec<u8>],
) -> Result<&'b [u8], String> {
    let buffer = view.buffer().index();
    let data = buffers
        .get(buffer)
        .ok_or_else(|| format!("buffer {buffer} is not loaded"))?;
    let start = view.offset();
    let end = start
        .checked_add(view.length())
        .filter(|&end| end <= data.len())
        .ok_or_else(|| {
            format!(
                "bufferView {} spans bytes {start}..{} but buffer {buffer} has {}",
                view.index(),
                start.saturating_add(view.length()),
                data.len()
            )
        })?;
    Ok(&data[start..end])
}

/// A strided run of `count` elements of `element_size` bytes starting at `offset` in `bytes`.
fn element_run<'b>(
    bytes: &'b [u8],
    offset: usize,
    stride: usize,
    count: usize,
    element_size: usize,
    what: &str,
) -> Result<(&'b [u8], usize), String> {
    if stride < element_size {
        return Err(format!(
            "{what}: byteStride {stride} is smaller than an element ({element_size} bytes)"
        ));
    }
    if count == 0 {
        return Ok((&[], stride));
    }
    let needed = (count - 1)
        .checked_mul(stride)
        .and_then(|n| n.checked_add(element_size))
        .and_then(|n| n.checked_add(offset));
    match needed {
        Some(end) if end <= bytes.len() => Ok((&bytes[offset..end], stride)),
        _ => Err(format!(
            "{what}: {count} elements of {element_size} bytes at offset {offset}, stride {stride} reach past the {} bytes available",
            bytes.len()
        )),
    }
}

/// Calls `visit(element_index, element_bytes)` for every element of the accessor: first the
/// dense data (if the accessor has a buffer view), then the sparse substitutions in order.
fn visit_elements(
    accessor: &gltf::Accessor<'_>,
    buffers: &[Vec<u8>],
    element_size: usize,
    mut visit: impl FnMut(usize, &[u8]),
) -> Result<(), AccessorProblem> {
    let count = accessor.count();
    if let Some(view) = accessor.view() {
        let bytes = view_bytes(&view, buffers).map_err(|e| problem(accessor, e))?;
        let stride = view.stride().unwrap_or(element_size);
        let (run, stride) = element_run(
            bytes,
            accessor.offset(),
            stride,
            count,
            element_size,
            "data",
        )
        .map_err(|e| problem(accessor, e))?;
        for i in 0..count {
            visit(i, &run[i * stride..i * stride + element_size]);
        }
    }
    if let Some(sparse) = accessor.sparse() {
        let sparse_count = sparse.count();
        let indices = sparse.indices();
        let index_type = match indices.index_type() {
            gltf::accessor::sparse::IndexType::U8 => DataType::U8,
            gltf::accessor::sparse::IndexType::U16 => DataType::U16,
            gltf::accessor::sparse::IndexType::U32 => DataType::U32,
        };
        let index_size = component_size(index_type);
        let index_bytes = view_bytes(&indices.view(), buffers).map_err(|e| problem(accessor, e))?;
        let (index_run, index_stride) = element_run(
            index_bytes,
            indices.offset(),
            index_size,
            sparse_count,
            index_size,
            "sparse indices",
        )
        .map_err(|e| problem(accessor, e))?;
        let values = sparse.values();
        let value_bytes = view_bytes(&values.view(), buffers).map_err(|e| problem(accessor, e))?;
        let (value_run, value_stride) = element_run(
            value_bytes,
            values.offset(),
            element_size,
            sparse_count,
            element_size,
            "sparse values",
        )
        .map_err(|e| problem(accessor, e))?;
        for s in 0..sparse_count {
            let target = read_index(&index_run[s * index_stride..], index_type)
                .map_or(usize::MAX, |t| t as usize);
            if target >= count {
                return Err(problem(
                    accessor,
                    format!("sparse index {target} is past the accessor's {count} elements"),
                ));
            }
            visit(
                target,
                &value_run[s * value_stride..s * value_stride + element_size],
            );
        }
    }
    Ok(())
}

/// The largest element count accepted for an accessor without a buffer view (its elements are
/// zeros plus sparse substitutions, so the file's size does not bound it).
const MAX_VIEWLESS_COUNT: usize = 1 << 26;

/// Checks, before anything is allocated, that the accessor's count is backed by data.
fn check_count(
    accessor: &gltf::Accessor<'_>,
    buffers: &[Vec<u8>],
    element_size: usize,
) -> Result<usize, AccessorProblem> {
    let count = accessor.count();
    match accessor.view() {
        Some(view) => {
            let bytes = view_bytes(&view, buffers).map_err(|e| problem(accessor, e))?;
            let stride = view.stride().unwrap_or(element_size);
            element_run(
                bytes,
                accessor.offset(),
                stride,
                count,
                element_size,
                "data",
            )
            .map_err(|e| problem(accessor, e))?;
        }
        None if count > MAX_VIEWLESS_COUNT => {
            return Err(problem(
                accessor,
                format!("count {count} without a bufferView exceeds {MAX_VIEWLESS_COUNT}"),
            ));
        }
        None => {}
    }
    Ok(count)
}

/// Reads an accessor as `f32` components into a flat vector (components per element follow
/// the accessor's type). `allowed` lists the element shapes the caller accepts. Elements
/// without data (no buffer view) are zero.
pub(crate) fn read_f32(
    accessor: &gltf::Accessor<'_>,
    buffers: &[Vec<u8>],
    allowed: &[Dimensions],
) -> Result<Vec<f32>, AccessorProblem> {
    let dimensions = accessor.dimensions();
    if !allowed.contains(&dimensions) {
        return Err(problem(
            accessor,
            format!("has type {dimensions:?}, expected one of {allowed:?}"),
        ));
    }
    let components = component_count(dimensions);
    let data_type = accessor.data_type();
    let csize = component_size(data_type);
    let normalized = accessor.normalized();
    let total = check_count(accessor, buffers, components * csize)?
        .checked_mul(components)
        .ok_or_else(|| problem(accessor, "count overflows"))?;
    let mut out = vec![0.0f32; total];
    visit_elements(accessor, buffers, components * csize, |i, element| {
        let dst = &mut out[i * components..(i + 1) * components];
        for (c, value) in dst.iter_mut().enumerate() {
            *value = read_component(&element[c * csize..], data_type, normalized);
        }
    })?;
    Ok(out)
}

/// Reads a scalar unsigned-integer accessor (vertex indices).
pub(crate) fn read_indices(
    accessor: &gltf::Accessor<'_>,
    buffers: &[Vec<u8>],
) -> Result<Vec<u32>, AccessorProblem> {
    let data_type = accessor.data_type();
    if accessor.dimensions() != Dimensions::Scalar
        || !matches!(data_type, DataType::U8 | DataType::U16 | DataType::U32)
        || accessor.normalized()
    {
        return Err(problem(
            accessor,
            format!(
                "indices must be unnormalised SCALAR u8/u16/u32, found {:?} {data_type:?}",
                accessor.dimensions()
            ),
        ));
    }
    let mut out = vec![0u32; check_count(accessor, buffers, component_size(data_type))?];
    visit_elements(
        accessor,
        buffers,
        component_size(data_type),
        |i, element| {
            out[i] = read_index(element, data_type).unwrap_or(0);
        },
    )?;
    Ok(out)
}
