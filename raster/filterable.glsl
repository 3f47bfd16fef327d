// The moment families' kinds as their shaders read them (raster/filterable_lookup.comp,
// raster/filterable_moments.comp): MomentKind's order (raster/filterable.h).
const uint kMomentVsm = 0u;
const uint kMomentEsm = 1u;
const uint kMomentEvsm2 = 2u;
const uint kMomentEvsm4 = 3u;
const uint kMomentMsm = 4u;  // LookupParams::moments: moment bias, unused, variant (1 hausdorff), storage bits
