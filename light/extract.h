/* Ground-truth light extraction from an HDR equirectangular panorama (the paper's dataset
 * section; DESIGN.md "Light extraction"; every rule and constant in docs/EXTRACTION.md).
 *
 * Intensity is luminance Y = 0.2126 R + 0.7152 G + 0.0722 B of the linear panorama, and a pixel's
 * energy is Y times its solid angle (light/equirect.h). P0 is the peak Y, M the median Y.
 *  1. Detection: take the brightest free pixel; grow an 8-connected region from it (wrapping in
 *     longitude, not across the poles) over free pixels with Y >= peak * region_frac (1/3); mask
 *     it, and mask its halo (pixels reached along paths that never rise above 1.1 x the lowest Y
 *     met on the path, down to the floor) so that a light's tail does not come back as a new
 *     light. Repeat while the free peak is >= the floor detect_median * M (3 M), the free energy
 *     above the floor is >= keep_frac of the strongest region's, up to max_candidates regions.
 *  2. Keep the regions with energy >= keep_frac (10%) of the strongest region's energy (then the
 *     max_lights strongest). "Energy" is the region's measured luminance energy sum(Y * dOmega).
 *  3. Direction: solid-angle-weighted centre of mass of the region's pixel directions.
 *     Size: an ellipse fitted to the region (solid-angle-weighted second moments in azimuthal-
 *     equidistant coordinates around the direction, plus each pixel's own extent); s = the solid
 *     angle of a cap whose angular radius is the mean of the two semi-axes: 2pi(1 - cos r).
 *  4. Supports: every detected region (kept or not) with its halo, grown further along non-rising
 *     paths over pixels with Y >= max(peak * support_frac, 1.5 M).
 *     Ambient: mean RGB (solid-angle weighted) of the pixels with Y < ambient_frac * P0 (5%)
 *     outside every support; if there are none, of all pixels outside the supports (a scene of
 *     low dynamic range: what is left); if none either, of all pixels.
 *  5. Colour: the region's mean RGB, then refined by non-negative least squares so that a diffuse
 *     sphere lit by the lights (pl_render_sphere_lights, each light alone with unit colour) matches
 *     the sphere lit by the masked panorama (pl_render_sphere_envmap): the panorama minus the
 *     ambient, clamped at 0, on the supports and 0 elsewhere. Per channel. The fitted c is the SG
 *     peak radiance of eq. (4) with that s; a lobe then carries c * pl_sg_integral(s) (about
 *     c s / 2). A light whose fitted colour is 0 in every channel is dropped.
 *  6. Distance: the panoramas have no depth, so it is ASSUMED from a room box (pl_room): the
 *     distance along the direction from the camera to the box's wall, floor or ceiling.
 * Lights are sorted by fitted energy, strongest first. Deterministic (ties broken by raster
 * order). Cost: a few sorts and flood fills over the pixels, plus 1 + N sphere renders;
 * about 0.1 s for 1024 x 512 on this machine class. */
#ifndef PL_LIGHT_EXTRACT_H
#define PL_LIGHT_EXTRACT_H

#include "core/image.h"
#include "parlight.h"

/* The assumed room: an axis-aligned box around the camera, metres. The floor is camera_height
 * below the camera, the ceiling room_height - camera_height above it, the walls half_width to the
 * left/right (x) and half_depth in front/behind (z). Defaults: 2.8 m ceiling, camera at 1.6 m,
 * a 6 m x 6 m room centred on the camera. */
typedef struct pl_room {
    double room_height;   /* floor to ceiling, > camera_height */
    double camera_height; /* floor to camera, > 0 */
    double half_width;    /* camera to the +-x walls, > 0 */
    double half_depth;    /* camera to the +-z walls, > 0 */
} pl_room;

typedef struct pl_extract_params {
    int max_lights;       /* keep at most this many (1..PL_MAX_LIGHTS), default PL_MAX_LIGHTS */
    int max_candidates;   /* detection iterations, 1..256, default 128 */
    double detect_median; /* detection floor: peaks >= detect_median x the median Y, default 3 */
    double region_frac;   /* region growth stops under peak * region_frac, default 1/3 */
    double ambient_frac;  /* ambient = pixels under P0 * ambient_frac, default 0.05 */
    double keep_frac;     /* keep regions with >= keep_frac of the strongest's energy, 0.10 */
    double support_frac;  /* support growth for the colour fit, default 0.01 */
    int refine;           /* 1: least-squares colour refinement (default); 0: mean colours */
    int sphere_size;      /* render size for the refinement, 16..512, default 32 */
    pl_room room;
} pl_extract_params;

/* Per-light diagnostics, in the order of the output lights. */
typedef struct pl_extract_light_info {
    double region_energy; /* sum(Y dOmega) over the detected region */
    double fitted_energy; /* luminance(c) * pl_sg_integral(s) after refinement */
    double peak;          /* peak Y of the region */
    int region_pixels, support_pixels;
} pl_extract_light_info;

typedef struct pl_extract_info {
    double peak;         /* P0 */
    double total_energy; /* sum(Y dOmega) over the panorama */
    double median;       /* median pixel Y (the supports' floor is 1.5 x this) */
    double floor;        /* detection floor: detect_median x median (at least 1e-6 P0) */
    int n_candidates;    /* regions detected before the 10% rule */
    int n_dropped_fit;   /* kept regions dropped because their fitted colour was 0 */
    double ms_detect, ms_refine, ms_total;
    pl_extract_light_info light[PL_MAX_LIGHTS];
} pl_extract_info;

void pl_extract_default_params(pl_extract_params *p);
/* Checks the parameters (PL_E_ARG naming the field). */
int pl_extract_check_params(const pl_extract_params *p);

/* Extracts lights + ambient from a 2:1 panorama (width = 2 * height >= 8; values >= 0 finite,
 * as pl_hdr_read gives). out->lights[i].distance_m comes from the room assumption. info may be
 * NULL. Allocates only temporary buffers. PL_E_ARG for a bad panorama or parameters. A panorama
 * that is all zero gives no lights and zero ambient. */
int pl_extract_lights(const pl_image_f32 *pano, const pl_extract_params *p, pl_lighting *out,
                      pl_extract_info *info);

/* Distance (metres) from the camera along unit direction dir to the room box. */
double pl_room_distance(const pl_room *room, const float dir[3]);

#endif
