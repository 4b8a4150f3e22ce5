/*
 * scatterbake_table.h: C interface to scatterbake tables (.sbt), for C and C++ renderers.
 *
 * The functions are exported by the C dynamic library of the workspace crate `capi/`
 * (`cargo build -p scatterbake-capi --release` produces target/release/libscatterbake_table.so,
 * .dylib or scatterbake_table.dll). Link with -lscatterbake_table. The library does all the
 * verification (magic, format version: newer majors are refused with an error naming the
 * version, newer minors are read and header fields it does not know are ignored; SHA-256 of the
 * header and of the compressed and uncompressed payload, sizes) with the same code as the Rust
 * reader, so a table that opens here is bit-identical to what the Rust writer wrote.
 *
 * Formats 1.x, 2.x and 3.x are read; a 2.0 table whose values are stored as 16-bit codes or
 * that has derived channels is returned decoded (every channel, derived ones included, as
 * float32). A 3.0 table may have even-periodic axes (sbt_axis_period > 0), which store only the
 * coordinates 0 to period/2.
 *
 * Data layout: row-major float32, axes in header order, channel index innermost:
 *     value(i_0, ..., i_{n-1}, c) = data[((i_0 * len_1 + i_1) * ... + i_{n-1}) * n_channels + c]
 * Lookup: sbt_sample() interpolates multilinearly in the stored axis coordinates, clamping
 * coordinates outside an axis to its end points (no extrapolation). On an even-periodic axis
 * of period P the coordinate x is first folded into the stored half, in double precision:
 *     r = fmod(fabs(x), P);  if (r > 0.5 * P) r = P - r;
 * (fmod is exact, so every reader gets the same bits; the value at x equals the value at -x,
 * x + P and P - x), then r is looked up as above. A renderer that interpolates the samples
 * itself folds the same way.
 *
 * All returned pointers stay valid until sbt_close(). Out-of-range indices return 0 or NULL.
 * No call aborts the host process: an internal error is caught and reported as a failure
 * (NULL with a message from sbt_open, 0 / NULL / -1 from the other calls).
 */
#ifndef SCATTERBAKE_TABLE_H
#define SCATTERBAKE_TABLE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct SbtTable sbt_table;

/* Open and fully verify a table (every structural rule of docs/table-format.md; uncompressed
 * payload at most 4 GiB). NULL on failure, with a message in err (if not NULL). */
sbt_table *sbt_open(const char *path, char *err, size_t err_len);
/* Like sbt_open with another payload limit in bytes (0 = the default 4 GiB). */
sbt_table *sbt_open_limit(const char *path, uint64_t max_payload_bytes, char *err, size_t err_len);
/* Like sbt_open_limit, but a tensor-train table (schema fur-medulla-tt/1, e.g. the shipped
 * assets/fur-medulla/ *.sbt) is checked (ranks, dims, core offsets, sizes, the memory and the
 * multiply-adds of the reconstruction: docs/table-format.md "Tensor-train tables") and
 * reconstructed into the dense table it holds (its source axes and channel; values
 * bit-identical to the Rust reader's; a value that is not finite is refused). The limit
 * (0 = 4 GiB) also bounds the reconstruction's memory (output and intermediates). Any other table opens as with sbt_open_limit. */
sbt_table *sbt_open_reconstructed(const char *path, uint64_t max_payload_bytes, char *err, size_t err_len);
/* Open one entry of a table: entry[0 .. n_entry) fixes the first n_entry axes at these indices
 * (e.g. {i_radius, i_wavelength, i_elevation} of a raytrace-phase-2d table; n_entry 0 opens the
 * whole table). The file is verified exactly as by sbt_open (every checksum over the whole
 * payload, which streams past in fixed-size chunks) and only the entry's samples are kept, so
 * memory is bounded by the entry, not by the table (docs/table-format.md, "Reading one entry").
 * The table keeps every axis: a fixed axis has length 1 and holds its chosen coordinate, so
 * sbt_sample takes one coordinate per axis as before (any value for a fixed axis). NULL on
 * failure (a refused file, more indices than axes, an index beyond its axis naming the axis,
 * memory exhausted), with a message in err. */
sbt_table *sbt_open_slice(const char *path, const size_t *entry, size_t n_entry, char *err, size_t err_len);
/* Like sbt_open_slice with another limit on the whole uncompressed payload (0 = 4 GiB). */
sbt_table *sbt_open_slice_limit(const char *path, const size_t *entry, size_t n_entry,
                                uint64_t max_payload_bytes, char *err, size_t err_len);
/* Free a table (NULL is ignored). */
void sbt_close(sbt_table *t);

/* The verified JSON header (schema, axes, channels, attributes, provenance, payload), as this
 * library version understands it: fields added by a newer minor version are not included. */
const char *sbt_header_json(const sbt_table *t);

size_t sbt_num_axes(const sbt_table *t);
const char *sbt_axis_name(const sbt_table *t, size_t axis);
const char *sbt_axis_unit(const sbt_table *t, size_t axis);
size_t sbt_axis_len(const sbt_table *t, size_t axis);
/* sbt_axis_len(t, axis) coordinates, strictly increasing. */
const double *sbt_axis_coords(const sbt_table *t, size_t axis);
/* Period P of an even-periodic axis (format 3.0: f(x + P) = f(x) = f(-x), the axis stores
 * 0 to P/2 and sbt_sample folds its coordinate, see above); 0 for any other axis or an
 * out-of-range index. An axis that sbt_open_slice fixed has length 1 and period 0. */
double sbt_axis_period(const sbt_table *t, size_t axis);

size_t sbt_num_channels(const sbt_table *t);
const char *sbt_channel_name(const sbt_table *t, size_t channel);
const char *sbt_channel_unit(const sbt_table *t, size_t channel);

/* The samples (see the layout above) and their count. */
const float *sbt_data(const sbt_table *t);
size_t sbt_data_len(const sbt_table *t);

/* Multilinear lookup of every channel at coords[0..n_coords) (one per axis, axis units; folded
 * on an even-periodic axis, see above). Writes sbt_num_channels(t) doubles to out (n_out must
 * be at least that). 0 on success, -1 on bad arguments (wrong arity, NaN coordinate, infinite
 * coordinate of an even-periodic axis, NULL pointers, short out). */
int sbt_sample(const sbt_table *t, const double *coords, size_t n_coords, double *out, size_t n_out);

/* Convenience (header-only): index of the channel called name, or -1. */
static inline long sbt_channel_index(const sbt_table *t, const char *name) {
    size_t n = sbt_num_channels(t);
    for (size_t c = 0; c < n; ++c) {
        const char *a = sbt_channel_name(t, c);
        const char *b = name;
        while (*a && *a == *b) { ++a; ++b; }
        if (*a == 0 && *b == 0) return (long)c;
    }
    return -1;
}

#ifdef __cplusplus
}
#endif

#endif /* SCATTERBAKE_TABLE_H */
