//! Per-dispatch timestamps and pipeline statistics on the ash path (`VkOptions::profile`):
//! `vkCmdWriteTimestamp` before and after each dispatch, and a pipeline-statistics query of
//! compute-shader invocations around it, read back once the submission has been waited for.
//! What the device lacks is said ([`QuerySupport::describe`]), not guessed.

use super::{fail, VkError};
use ash::vk;
use std::sync::Mutex;
use std::time::Duration;

/// Which queries the device has, and which of them `VkOptions::profile` turned on.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct QuerySupport {
    /// `timestampValidBits` of the compute queue family (0: no timestamps on it).
    pub timestamp_valid_bits: u32,
    /// `timestampPeriod`: nanoseconds per timestamp tick.
    pub timestamp_period_ns: f32,
    /// Whether the device has `pipelineStatisticsQuery`.
    pub has_pipeline_statistics: bool,
    /// Timestamps are written around each dispatch.
    pub timestamps: bool,
    /// Compute-shader invocations are counted per dispatch.
    pub invocations: bool,
}

impl QuerySupport {
    pub(crate) fn of(
        limits: &vk::PhysicalDeviceLimits,
        family: &vk::QueueFamilyProperties,
        pipeline_statistics: bool,
        asked: bool,
    ) -> Self {
        let bits = family.timestamp_valid_bits;
        let period = limits.timestamp_period;
        QuerySupport {
            timestamp_valid_bits: bits,
            timestamp_period_ns: period,
            has_pipeline_statistics: pipeline_statistics,
            timestamps: asked && bits > 0 && period > 0.0,
            invocations: asked && pipeline_statistics,
        }
    }

    /// One line on what is measured, and why something is not.
    pub fn describe(&self) -> String {
        let ts = if self.timestamp_valid_bits == 0 {
            "no timestamps (timestampValidBits is 0 on the compute queue)".to_string()
        } else {
            format!(
                "timestamps: {} valid bits, {} ns per tick",
                self.timestamp_valid_bits, self.timestamp_period_ns
            )
        };
        let stats = if self.has_pipeline_statistics {
            "pipeline statistics: compute-shader invocations"
        } else {
            "no pipeline statistics (pipelineStatisticsQuery is not supported)"
        };
        format!("{ts}; {stats}")
    }

    fn mask(&self) -> u64 {
        match self.timestamp_valid_bits {
            0 => 0,
            b if b >= 64 => u64::MAX,
            b => (1u64 << b) - 1,
        }
    }
}

/// What was measured of one dispatch.
#[derive(Clone, Debug, PartialEq)]
pub struct DispatchSample {
    pub entry: String,
    pub groups: [u32; 3],
    /// Wall time on the host: recording, submission and the fence wait.
    pub host: Duration,
    /// Between the timestamps before and after the dispatch (`None`: no timestamps).
    pub device: Option<Duration>,
    /// Compute-shader invocations the driver counted (`None`: no pipeline statistics).
    pub invocations: Option<u64>,
}

/// The query pools (two timestamps, one statistics query; reset in the command buffer before
/// each use) and the samples not yet taken.
pub(crate) struct Queries {
    support: QuerySupport,
    timestamps: vk::QueryPool,
    stats: vk::QueryPool,
    samples: Mutex<Vec<DispatchSample>>,
}

impl Queries {
    /// The pools `support` turns on; `None` when it turns on none.
    pub fn new(device: &ash::Device, support: QuerySupport) -> Result<Option<Self>, VkError> {
        if !support.timestamps && !support.invocations {
            return Ok(None);
        }
        let mut q = Queries {
            support,
            timestamps: vk::QueryPool::null(),
            stats: vk::QueryPool::null(),
            samples: Mutex::new(Vec::new()),
        };
        // SAFETY: plain object creation; destroyed by `destroy` (or here on failure).
        unsafe {
            if support.timestamps {
                q.timestamps = device
                    .create_query_pool(
                        &vk::QueryPoolCreateInfo::default()
                            .query_type(vk::QueryType::TIMESTAMP)
                            .query_count(2),
                        None,
                    )
                    .map_err(fail("vkCreateQueryPool (timestamps)"))?;
            }
            if support.invocations {
                let made = device.create_query_pool(
                    &vk::QueryPoolCreateInfo::default()
                        .query_type(vk::QueryType::PIPELINE_STATISTICS)
                        .query_count(1)
                        .pipeline_statistics(vk::QueryPipelineStatisticFlags::COMPUTE_SHADER_INVOCATIONS),
                    None,
                );
                match made {
                    Ok(p) => q.stats = p,
                    Err(e) => {
                        q.destroy(device);
                        return Err(fail("vkCreateQueryPool (pipeline statistics)")(e));
                    }
                }
            }
        }
        Ok(Some(q))
    }

    /// Destroys the pools (the device is idle).
    pub fn destroy(&self, device: &ash::Device) {
        // SAFETY: no submission uses them any more; null handles are ignored by Vulkan.
        unsafe {
            device.destroy_query_pool(self.timestamps, None);
            device.destroy_query_pool(self.stats, None);
        }
    }

    /// Records the queries' reset, the first timestamp and the statistics query's begin.
    ///
    /// # Safety
    /// `cmd` is recording, outside a render pass, and the next command recorded is the dispatch.
    pub unsafe fn begin(&self, d: &ash::Device, cmd: vk::CommandBuffer) {
        if self.support.timestamps {
            d.cmd_reset_query_pool(cmd, self.timestamps, 0, 2);
            d.cmd_write_timestamp(cmd, vk::PipelineStageFlags::TOP_OF_PIPE, self.timestamps, 0);
        }
        if self.support.invocations {
            d.cmd_reset_query_pool(cmd, self.stats, 0, 1);
            d.cmd_begin_query(cmd, self.stats, 0, vk::QueryControlFlags::empty());
        }
    }

    /// Records the statistics query's end and the second timestamp, after the dispatch.
    ///
    /// # Safety
    /// As [`Queries::begin`], which was recorded before the dispatch.
    pub unsafe fn end(&self, d: &ash::Device, cmd: vk::CommandBuffer) {
        if self.support.invocations {
            d.cmd_end_query(cmd, self.stats, 0);
        }
        if self.support.timestamps {
            d.cmd_write_timestamp(cmd, vk::PipelineStageFlags::BOTTOM_OF_PIPE, self.timestamps, 1);
        }
    }

    /// Reads what the waited-for submission measured and keeps it as a sample.
    pub fn collect(
        &self,
        d: &ash::Device,
        entry: &str,
        groups: [u32; 3],
        host: Duration,
    ) -> Result<(), VkError> {
        let flags = vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT;
        // SAFETY: the queries were written by a submission that has completed.
        let device = if self.support.timestamps {
            let mut t = [0u64; 2];
            unsafe { d.get_query_pool_results(self.timestamps, 0, &mut t, flags) }
                .map_err(fail("reading the timestamps"))?;
            let ticks = t[1].wrapping_sub(t[0]) & self.support.mask();
            Some(Duration::from_nanos((ticks as f64 * self.support.timestamp_period_ns as f64) as u64))
        } else {
            None
        };
        let invocations = if self.support.invocations {
            let mut n = [0u64; 1];
            // SAFETY: as above.
            unsafe { d.get_query_pool_results(self.stats, 0, &mut n, flags) }
                .map_err(fail("reading the pipeline statistics"))?;
            Some(n[0])
        } else {
            None
        };
        self.samples.lock().unwrap_or_else(|e| e.into_inner()).push(DispatchSample {
            entry: entry.to_string(),
            groups,
            host,
            device,
            invocations,
        });
        Ok(())
    }

    /// The samples since the last call.
    pub fn take(&self) -> Vec<DispatchSample> {
        std::mem::take(&mut *self.samples.lock().unwrap_or_else(|e| e.into_inner()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timestamp_mask_follows_the_valid_bits() {
        let s = |bits| QuerySupport { timestamp_valid_bits: bits, ..Default::default() }.mask();
        assert_eq!(s(0), 0);
        assert_eq!(s(36), (1 << 36) - 1);
        assert_eq!(s(64), u64::MAX);
    }

    #[test]
    fn missing_queries_are_said() {
        let none = QuerySupport::default().describe();
        assert!(
            none.contains("timestampValidBits is 0") && none.contains("pipelineStatisticsQuery"),
            "{none}"
        );
    }
}
