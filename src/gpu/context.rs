//! A headless wgpu context: instance, adapter, device and queue without a window.

use std::io::Write;

use super::GpuError;

/// A device and queue created without a surface, for offscreen rendering, tests and benchmarks.
///
/// Applications that already have a device do not need this: every other type in
/// [`crate::gpu`] takes a `&wgpu::Device` / `&wgpu::Queue`.
pub struct Context {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
}

impl Context {
    /// The optional features the project's renderers use, requested where the adapter has them.
    pub const FEATURES: wgpu::Features = wgpu::Features::INDIRECT_FIRST_INSTANCE
        .union(wgpu::Features::TIMESTAMP_QUERY)
        .union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS);

    /// Creates a device on the first adapter wgpu picks (the `WGPU_BACKEND` and
    /// `WGPU_ADAPTER_NAME` environment variables still apply).
    ///
    /// Only features the adapter has are requested ([`Context::FEATURES`] where available).
    /// `INDIRECT_FIRST_INSTANCE` lets each region's indirect draw carry its region number as
    /// `first_instance`, which the shader's strip colouring reads (without it wgpu zeroes the
    /// field and every strip gets the same colour), and puts a [`super::Crowd`] on its
    /// first-instance path ([`super::CrowdPath`]). `TIMESTAMP_QUERY` lets the crowd benchmark
    /// time the GPU with timestamps, and `TIMESTAMP_QUERY_INSIDE_ENCODERS` lets it time the
    /// compute passes before the render pass too. Multi-draw indirect itself needs no feature.
    pub fn headless() -> Result<Context, GpuError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter =
            pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default()))
                .map_err(|source| GpuError::NoAdapter { source })?;
        let required_features = adapter.features() & Context::FEATURES;
        let descriptor = wgpu::DeviceDescriptor {
            label: Some("morphlod headless device"),
            required_features,
            // The adapter's own limits, not WebGPU's defaults: large meshes need big buffers.
            required_limits: adapter.limits(),
            ..Default::default()
        };
        let (device, queue) =
            pollster::block_on(adapter.request_device(&descriptor)).map_err(|source| {
                GpuError::RequestDevice {
                    adapter: adapter.get_info().name,
                    source,
                }
            })?;
        Ok(Context {
            instance,
            adapter,
            device,
            queue,
        })
    }

    /// Name, backend, driver and device type of the adapter in use.
    pub fn adapter_info(&self) -> wgpu::AdapterInfo {
        self.adapter.get_info()
    }

    /// Whether indirect draws may carry a nonzero `first_instance` (strip colouring works).
    pub fn first_instance_enabled(&self) -> bool {
        self.device
            .features()
            .contains(wgpu::Features::INDIRECT_FIRST_INSTANCE)
    }
}

/// The context every GPU test uses, with the one skip policy for machines without a GPU.
///
/// * An adapter exists: `Ok(Some(context))`.
/// * No adapter under CI ([`crate::ci::is_ci`]: `CI` set to anything but empty, `0` or
///   `false`): `Err(NoAdapter)`, so the test fails — CI must not pass by skipping every GPU test.
/// * No adapter outside CI: prints why on stderr and returns `Ok(None)`; the test returns early.
/// * Any other failure (the adapter cannot create a device): `Err`, in and out of CI.
pub fn test_context() -> Result<Option<Context>, GpuError> {
    match Context::headless() {
        Ok(context) => Ok(Some(context)),
        Err(error @ GpuError::NoAdapter { .. }) => {
            if crate::ci::is_ci() {
                // The test harness prints the error with Debug; show the install hint too.
                eprintln!("GPU test failed because CI is set: {error}");
                Err(error)
            } else {
                // Written to the stderr handle, not with eprintln!, which the test harness
                // captures: a skip must be visible in a normal `cargo test` run.
                let _ = writeln!(
                    std::io::stderr(),
                    "skipping GPU test (set CI=1 to make this an error): {error}"
                );
                Ok(None)
            }
        }
        Err(error) => Err(error),
    }
}
