//! Where a record's irradiance comes from: the one place that lists the record sources.
//! Every source turns the same [`super::RecordSite`]s (placed by the same placement) into
//! the same [`super::Record`]s (p, n, R, E and its gradients), which the same splat,
//! resolve and temporal machinery use; a source differs only in how it fills them, inside
//! [`super::RecordPass::compute`]. A new source is one more variant here, one more arm in
//! `RecordPass::compute_batch`, and its pass beside the others in this folder: splat/ and
//! resolve/ never hear of it. Photon records are the one source that places its own
//! records (along the photon array, before pixel placement: `Renderer::render_cached_frame`
//! seeds an empty cache with them); placement then fills the holes with plane records.

/// How records get their irradiance (`--records`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, clap::ValueEnum)]
pub enum RecordSource {
    /// Hemisphere planes (thesis chapter 4): P x P rays from the record, traced and shaded
    /// (`hemisphere_plane.wgsl`), optionally refined (`plane_refine_select.wgsl`), reduced to E,
    /// R and the gradients (`record_reduce.wgsl`, algorithms.md 3.3). Radiance records also
    /// project their planes onto HSH. More bounces come from the surface bounce cache.
    #[default]
    Planes,
    /// Virtual point lights (instant caching, seed 003): one visibility ray from the
    /// record to each VPL traced from the lights for the scene (`crate::vpl`), summed with
    /// the bounded geometry term (`vpl_gather.wgsl`, `src/records/vpl_gather.rs`). VPL paths carry
    /// every bounce. Irradiance records only; radiance records keep their planes.
    Vpl,
    /// The photon map alone (photon-mapped irradiance caching, thesis chapter 6): records
    /// placed along the photon array before any pixel asks (Algorithm 6) and reduced from
    /// their neighbourhood's photons (Algorithm 7, `photon_reduce.wgsl`,
    /// `src/records/photon_records.rs`); the pixels they leave uncovered get plane records.
    /// Photon paths carry every bounce (plane records in the holes use the bounce cache).
    Photons,
}

impl RecordSource {
    /// The name `--records` takes.
    pub fn name(self) -> &'static str {
        match self {
            Self::Planes => "planes",
            Self::Vpl => "vpl",
            Self::Photons => "photons",
        }
    }
}
