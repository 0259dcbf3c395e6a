//! Per-pass timing for benchmarks: GPU timestamps around each compute pass where the adapter
//! supports them, and the wall clock of each submitted pass (waited on) always.

use web_time::Instant;

use super::{GpuContext, GpuError};

/// The time one labelled pass took.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PassTime {
    pub label: String,
    /// From timestamp queries, in milliseconds; `None` without TIMESTAMP_QUERY.
    pub gpu_ms: Option<f64>,
    /// Submit to completion, in milliseconds.
    pub wall_ms: f64,
}

pub struct PassTimer {
    query_set: Option<wgpu::QuerySet>,
    capacity: u32,
    labels: Vec<String>,
    wall_ms: Vec<f64>,
    started: Option<Instant>,
}

impl PassTimer {
    /// A timer for up to `capacity` passes.
    pub fn new(ctx: &GpuContext, capacity: u32) -> PassTimer {
        let capacity = capacity.min(wgpu::QUERY_SET_MAX_QUERIES / 2);
        let query_set = ctx
            .features
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| {
                ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("pass timer"),
                    ty: wgpu::QueryType::Timestamp,
                    count: capacity * 2,
                })
            });
        PassTimer {
            query_set,
            capacity,
            labels: Vec::new(),
            wall_ms: Vec::new(),
            started: None,
        }
    }

    /// Timestamp writes for the next pass (None when full or unsupported).
    pub fn begin(&mut self, label: &str) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        self.started = Some(Instant::now());
        let index = self.labels.len() as u32;
        self.labels.push(label.to_string());
        let qs = self.query_set.as_ref()?;
        (index < self.capacity).then_some(wgpu::ComputePassTimestampWrites {
            query_set: qs,
            beginning_of_pass_write_index: Some(2 * index),
            end_of_pass_write_index: Some(2 * index + 1),
        })
    }

    /// Waits for the pass just submitted and records its wall time.
    pub fn end(&mut self, ctx: &GpuContext) {
        let _ = ctx.device.poll(wgpu::PollType::wait_indefinitely());
        let ms = self
            .started
            .take()
            .map(|t| t.elapsed().as_secs_f64() * 1e3)
            .unwrap_or(0.0);
        self.wall_ms.push(ms);
    }

    /// Resolves the timestamps and returns every pass's times.
    pub fn finish(self, ctx: &GpuContext) -> Result<Vec<PassTime>, GpuError> {
        let n = (self.labels.len() as u32).min(self.capacity);
        let gpu: Vec<Option<f64>> = match &self.query_set {
            Some(qs) if n > 0 => {
                let size = (2 * n as u64) * 8;
                let resolve = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("timestamps"),
                    size,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                });
                let mut encoder = ctx
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
                encoder.resolve_query_set(qs, 0..2 * n, &resolve, 0);
                ctx.queue.submit([encoder.finish()]);
                let ticks: Vec<u64> = ctx.read_buffer("timestamps", &resolve)?;
                let period = ctx.queue.get_timestamp_period() as f64;
                (0..n as usize)
                    .map(|i| {
                        let (a, b) = (ticks[2 * i], ticks[2 * i + 1]);
                        (b >= a).then(|| (b - a) as f64 * period * 1e-6)
                    })
                    .collect()
            }
            _ => Vec::new(),
        };
        Ok(self
            .labels
            .into_iter()
            .enumerate()
            .map(|(i, label)| PassTime {
                label,
                gpu_ms: gpu.get(i).copied().flatten(),
                wall_ms: self.wall_ms.get(i).copied().unwrap_or(0.0),
            })
            .collect())
    }
}
