//! Values on their way from the device: what the viewer asks for in one frame and takes in
//! a later one, or what a batch run waits for.

use super::*;

/// What makes a [`Pending`]'s value from its arrived read-backs.
type Assemble<T> = Box<dyn FnOnce(&GpuContext) -> Result<T, GpuError>>;

/// A value assembled from read-backs on their way from the device: taken once they have all
/// arrived ([`Pending::take`]), or waited for natively ([`Pending::wait`]). What the viewer
/// holds between the frame that asks and the frame that uses the answer.
pub struct Pending<T> {
    /// The read-backs' arrival flags.
    pub(super) ready: Vec<crate::gpu::ReadyFlag>,
    pub(super) make: Option<Assemble<T>>,
    pub(super) value: Option<T>,
}

impl<T> std::fmt::Debug for Pending<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Pending")
            .field("reads", &self.ready.len())
            .field("taken", &self.value.is_some())
            .finish()
    }
}

impl<T> Pending<T> {
    /// A value that needs no read-back.
    pub fn ready(value: T) -> Pending<T> {
        Pending {
            ready: Vec::new(),
            make: None,
            value: Some(value),
        }
    }

    /// A value `make` builds from read-backs once every flag in `ready` is set.
    pub fn new(
        ready: Vec<crate::gpu::ReadyFlag>,
        make: impl FnOnce(&GpuContext) -> Result<T, GpuError> + 'static,
    ) -> Pending<T> {
        Pending {
            ready,
            make: Some(Box::new(make)),
            value: None,
        }
    }

    /// Whether every read-back has arrived (natively, lets the device progress first).
    pub fn is_ready(&self, ctx: &GpuContext) -> bool {
        ctx.poll();
        self.ready.iter().all(|r| r.is_set())
    }

    /// The value once everything has arrived, else `None` (ask again in a later frame).
    pub fn take(&mut self, ctx: &GpuContext) -> Option<Result<T, SessionError>> {
        if let Some(v) = self.value.take() {
            return Some(Ok(v));
        }
        if !self.is_ready(ctx) {
            return None;
        }
        let make = self.make.take()?;
        Some(make(ctx).map_err(SessionError::from))
    }

    /// The value, waiting for it natively (in the browser: an error unless it has arrived).
    pub fn wait(mut self, ctx: &GpuContext) -> Result<T, SessionError> {
        if let Some(v) = self.value.take() {
            return Ok(v);
        }
        ctx.wait_for(&self.ready)?;
        match self.make.take() {
            Some(make) => make(ctx).map_err(SessionError::from),
            None => Err(SessionError::State("a read-back taken twice".into())),
        }
    }
}
