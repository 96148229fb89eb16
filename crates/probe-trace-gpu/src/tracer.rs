//! One interface over the CPU twin and the GPU tracer: the [`Tracer`] trait, whose uploaded
//! fields are values the caller holds, and [`AnyTracer`], a boxed tracer of either kind.

use std::any::Any;

use crate::cpu::{CpuTracer, DiffuseOutput, TraceOutput};
use crate::error::{GpuError, TraceError, UploadError};
use crate::gpu::{GpuContext, GpuTracer};
use crate::input::{FieldOptions, Interpolation, IrradianceField, LightField, ProbeSelection};
use crate::ray::{DiffuseOptions, ShadingPoint, SurfaceQuery, TraceOptions, TraceRay};

/// What both tracers do: check and upload probe data, getting back a field you hold, then
/// trace rays through it or shade points from it.
///
/// An uploaded field is a value of the tracer's own type ([`CpuTracer`]: `CpuField`,
/// [`GpuTracer`]: `GpuField`), so tracing before uploading, or passing one tracer's field to
/// the other kind, does not compile. Fields are independent of each other: upload several
/// probe sets and trace through any of them in any order.
///
/// Code generic over `T: Tracer` runs on either; to choose at run time and hold the choice in
/// one type, use [`AnyTracer`].
pub trait Tracer {
    /// A light field and its probe selection, checked and uploaded.
    type Field;
    /// Irradiance and moment maps and their interpolation, checked and uploaded.
    type Irradiance;

    /// What the tracer runs on: `"cpu twin"`, or `"gpu: ADAPTER (BACKEND)"`.
    fn describe(&self) -> String;

    /// Checks a light field and its probe selection and uploads them.
    ///
    /// # Errors
    /// [`UploadError`] naming the bad slice, element or parameter, or the buffer that does not
    /// fit the device's limits.
    fn upload(
        &self,
        field: &LightField<'_>,
        selection: &ProbeSelection<'_>,
        options: &FieldOptions,
    ) -> Result<Self::Field, UploadError>;

    /// Checks irradiance and moment maps and the interpolation scheme and uploads them.
    ///
    /// # Errors
    /// As [`Self::upload`].
    fn upload_irradiance(
        &self,
        field: &IrradianceField<'_>,
        interpolation: &Interpolation<'_>,
    ) -> Result<Self::Irradiance, UploadError>;

    /// Traces `rays` through `field`, one result per ray, in order.
    ///
    /// # Errors
    /// [`TraceError::BadInput`] for a bad ray; [`TraceError::BadOption`] for bad options;
    /// [`TraceError::ForeignField`] for a field that another tracer uploaded (another
    /// [`GpuTracer`], or through [`AnyTracer`] one of the other kind); [`TraceError::Device`]
    /// if the device fails.
    fn trace(
        &mut self,
        field: &Self::Field,
        rays: &[TraceRay],
        options: &TraceOptions,
    ) -> Result<TraceOutput, TraceError>;

    /// The hybrid tracer's radiance: for each surface point found by an exact ray cast, the
    /// radiance the probes that see it hold ([`SurfaceQuery`]), one result per query, in
    /// order. HIT: a probe's texel shows the point (on its plane); UNKNOWN: none of
    /// the candidates does, and the point takes the radiance of the nearest point of its own
    /// surface that a near candidate sees (a few texels around its direction), else the
    /// closest candidate's texel in its direction; MISS: an escaped
    /// ray, the probes' sky along its direction. `options` gives the candidates
    /// (`nearest_candidates`); the march options are not used.
    ///
    /// # Errors
    /// [`TraceError::BadInput`] for a bad query; otherwise as [`Self::trace`].
    fn look_up(
        &mut self,
        field: &Self::Field,
        queries: &[SurfaceQuery],
        options: &TraceOptions,
    ) -> Result<TraceOutput, TraceError>;

    /// Shades `points` diffusely from `irradiance`, one result per point, in order.
    ///
    /// # Errors
    /// [`TraceError::BadInput`] for a bad point; otherwise as [`Self::trace`].
    fn shade_diffuse(
        &mut self,
        irradiance: &Self::Irradiance,
        points: &[ShadingPoint],
        options: &DiffuseOptions,
    ) -> Result<DiffuseOutput, TraceError>;
}

/// A light field uploaded by an [`AnyTracer`]: the underlying tracer's field, boxed.
pub struct AnyField {
    inner: Box<dyn Any + Send + Sync>,
    uploaded_by: String,
}

/// Irradiance probes uploaded by an [`AnyTracer`]: the underlying tracer's, boxed.
pub struct AnyIrradiance {
    inner: Box<dyn Any + Send + Sync>,
    uploaded_by: String,
}

impl std::fmt::Debug for AnyField {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AnyField")
            .field("uploaded_by", &self.uploaded_by)
            .finish_non_exhaustive()
    }
}

impl std::fmt::Debug for AnyIrradiance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AnyIrradiance")
            .field("uploaded_by", &self.uploaded_by)
            .finish_non_exhaustive()
    }
}

/// The object-safe form of [`Tracer`] that [`AnyTracer`] boxes.
trait ErasedTracer: Send {
    fn describe(&self) -> String;
    fn upload(
        &self,
        field: &LightField<'_>,
        selection: &ProbeSelection<'_>,
        options: &FieldOptions,
    ) -> Result<AnyField, UploadError>;
    fn upload_irradiance(
        &self,
        field: &IrradianceField<'_>,
        interpolation: &Interpolation<'_>,
    ) -> Result<AnyIrradiance, UploadError>;
    fn trace(
        &mut self,
        field: &AnyField,
        rays: &[TraceRay],
        options: &TraceOptions,
    ) -> Result<TraceOutput, TraceError>;
    fn look_up(
        &mut self,
        field: &AnyField,
        queries: &[SurfaceQuery],
        options: &TraceOptions,
    ) -> Result<TraceOutput, TraceError>;
    fn shade_diffuse(
        &mut self,
        irradiance: &AnyIrradiance,
        points: &[ShadingPoint],
        options: &DiffuseOptions,
    ) -> Result<DiffuseOutput, TraceError>;
}

/// The field `field` as tracer `tracer`'s own type, or [`TraceError::ForeignField`] when
/// another tracer uploaded it.
fn own_field<'a, T>(tracer: &T, field: &'a AnyField) -> Result<&'a T::Field, TraceError>
where
    T: Tracer,
    T::Field: 'static,
{
    field
        .inner
        .downcast_ref::<T::Field>()
        .ok_or_else(|| TraceError::ForeignField {
            uploaded_by: field.uploaded_by.clone(),
            tracer: Tracer::describe(tracer),
        })
}

impl<T> ErasedTracer for T
where
    T: Tracer + Send,
    T::Field: Send + Sync + 'static,
    T::Irradiance: Send + Sync + 'static,
{
    fn describe(&self) -> String {
        Tracer::describe(self)
    }

    fn upload(
        &self,
        field: &LightField<'_>,
        selection: &ProbeSelection<'_>,
        options: &FieldOptions,
    ) -> Result<AnyField, UploadError> {
        Ok(AnyField {
            inner: Box::new(Tracer::upload(self, field, selection, options)?),
            uploaded_by: Tracer::describe(self),
        })
    }

    fn upload_irradiance(
        &self,
        field: &IrradianceField<'_>,
        interpolation: &Interpolation<'_>,
    ) -> Result<AnyIrradiance, UploadError> {
        Ok(AnyIrradiance {
            inner: Box::new(Tracer::upload_irradiance(self, field, interpolation)?),
            uploaded_by: Tracer::describe(self),
        })
    }

    fn trace(
        &mut self,
        field: &AnyField,
        rays: &[TraceRay],
        options: &TraceOptions,
    ) -> Result<TraceOutput, TraceError> {
        let own = own_field::<T>(self, field)?;
        Tracer::trace(self, own, rays, options)
    }

    fn look_up(
        &mut self,
        field: &AnyField,
        queries: &[SurfaceQuery],
        options: &TraceOptions,
    ) -> Result<TraceOutput, TraceError> {
        let own = own_field::<T>(self, field)?;
        Tracer::look_up(self, own, queries, options)
    }

    fn shade_diffuse(
        &mut self,
        irradiance: &AnyIrradiance,
        points: &[ShadingPoint],
        options: &DiffuseOptions,
    ) -> Result<DiffuseOutput, TraceError> {
        let Some(own) = irradiance.inner.downcast_ref::<T::Irradiance>() else {
            return Err(TraceError::ForeignField {
                uploaded_by: irradiance.uploaded_by.clone(),
                tracer: Tracer::describe(self),
            });
        };
        Tracer::shade_diffuse(self, own, points, options)
    }
}

/// A tracer of either kind behind one type: a boxed [`Tracer`] whose fields are boxed too
/// ([`AnyField`], [`AnyIrradiance`]). For callers that pick the GPU or the CPU twin at run
/// time; [`AnyTracer::gpu_or_cpu`] makes that choice.
///
/// Passing it a field uploaded by a different `AnyTracer` of the other kind is the one mistake
/// the types cannot catch here: it is [`TraceError::ForeignField`].
pub struct AnyTracer {
    inner: Box<dyn ErasedTracer>,
}

impl std::fmt::Debug for AnyTracer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("AnyTracer")
            .field(&self.inner.describe())
            .finish()
    }
}

impl AnyTracer {
    /// Boxes `tracer`.
    pub fn new<T>(tracer: T) -> Self
    where
        T: Tracer + Send + 'static,
        T::Field: Send + Sync + 'static,
        T::Irradiance: Send + Sync + 'static,
    {
        Self {
            inner: Box::new(tracer),
        }
    }

    /// The GPU tracer on the default adapter ([`GpuContext::new`]) if one can be had, else the
    /// CPU twin (same algorithm, same answers) and the reason the GPU could not be used.
    pub fn gpu_or_cpu() -> (Self, Option<GpuError>) {
        match GpuContext::new().and_then(|context| GpuTracer::new(&context)) {
            Ok(gpu) => (Self::new(gpu), None),
            Err(error) => (Self::new(CpuTracer::new()), Some(error)),
        }
    }
}

impl Tracer for AnyTracer {
    type Field = AnyField;
    type Irradiance = AnyIrradiance;

    fn describe(&self) -> String {
        self.inner.describe()
    }

    fn upload(
        &self,
        field: &LightField<'_>,
        selection: &ProbeSelection<'_>,
        options: &FieldOptions,
    ) -> Result<AnyField, UploadError> {
        self.inner.upload(field, selection, options)
    }

    fn upload_irradiance(
        &self,
        field: &IrradianceField<'_>,
        interpolation: &Interpolation<'_>,
    ) -> Result<AnyIrradiance, UploadError> {
        self.inner.upload_irradiance(field, interpolation)
    }

    fn trace(
        &mut self,
        field: &AnyField,
        rays: &[TraceRay],
        options: &TraceOptions,
    ) -> Result<TraceOutput, TraceError> {
        self.inner.trace(field, rays, options)
    }

    fn look_up(
        &mut self,
        field: &AnyField,
        queries: &[SurfaceQuery],
        options: &TraceOptions,
    ) -> Result<TraceOutput, TraceError> {
        self.inner.look_up(field, queries, options)
    }

    fn shade_diffuse(
        &mut self,
        irradiance: &AnyIrradiance,
        points: &[ShadingPoint],
        options: &DiffuseOptions,
    ) -> Result<DiffuseOutput, TraceError> {
        self.inner.shade_diffuse(irradiance, points, options)
    }
}
