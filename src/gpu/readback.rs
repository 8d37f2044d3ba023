//! Reading GPU buffers back to the CPU: map a `MAP_READ` buffer and wait for it, and copy any
//! `COPY_SRC` buffer back through one. What the offscreen target's image readback and the
//! crowd's position probe share.

use std::sync::mpsc;

use super::GpuError;

/// Maps `buffer` (`MAP_READ`, its copy already submitted) for reading and waits for the device.
pub(super) fn wait_mapped(device: &wgpu::Device, buffer: &wgpu::Buffer) -> Result<(), GpuError> {
    let (sender, receiver) = mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |result| {
        // The receiver outlives the poll below; a failed send only means nobody waits.
        let _ = sender.send(result);
    });
    device.poll(wgpu::PollType::wait_indefinitely())?;
    match receiver.recv() {
        Ok(Ok(())) => Ok(()),
        Ok(Err(error)) => Err(GpuError::Map(error.to_string())),
        Err(_) => Err(GpuError::Map(
            "the map callback never ran after the device was polled".to_string(),
        )),
    }
}

/// Submits `encoder` followed by a copy of the whole of `source` (`COPY_SRC`, size a multiple
/// of 4) into a staging buffer, and returns its bytes once the GPU has run both.
pub(super) fn read_back(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mut encoder: wgpu::CommandEncoder,
    source: &wgpu::Buffer,
) -> Result<Vec<u8>, GpuError> {
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("morphlod read-back"),
        size: source.size(),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    encoder.copy_buffer_to_buffer(source, 0, &staging, 0, source.size());
    queue.submit([encoder.finish()]);
    wait_mapped(device, &staging)?;
    let bytes = staging
        .get_mapped_range(..)
        .map_err(|error| GpuError::Map(error.to_string()))?
        .to_vec();
    staging.unmap();
    Ok(bytes)
}
