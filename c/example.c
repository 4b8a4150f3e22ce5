/*
 * example.c: open a scatterbake table from C, print its axes (name, unit, length, first and
 * last coordinate, period of an even-periodic axis or 0) and channels, and look up a value.
 * Build (after `cargo build -p scatterbake-capi --release`):
 *     cc -std=c99 -Wall -I c c/example.c -L target/release -lscatterbake_table \
 *        -Wl,-rpath,$PWD/target/release -o sbt-example
 * Run:
 *     ./sbt-example tables/rainbow-mie.sbt [--reconstruct | --entry I,J,...] [--dump out.bin]
 *                   [COORD ...]
 * With --reconstruct the table is opened with sbt_open_reconstructed (a tensor-train table is
 * reconstructed into its dense table); with --entry 0,2,1 only that entry (indices of the
 * leading axes) is kept, with sbt_open_slice.
 * With --dump the payload is written as raw float32 little-endian (used by the tests to
 * compare bit for bit with the Rust writer). With COORDs (one per axis) every channel is
 * printed at that point, with the lookup formula of the library.
 */
#include "scatterbake_table.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: %s TABLE.sbt [--reconstruct | --entry I,J,...] [--dump OUT.bin] [COORD ...]\n",
                argv[0]);
        return 2;
    }
    int argi = 2, reconstruct = 0, sliced = 0;
    size_t entry[16], n_entry = 0;
    if (argi < argc && strcmp(argv[argi], "--reconstruct") == 0) {
        reconstruct = 1;
        ++argi;
    } else if (argi + 1 < argc && strcmp(argv[argi], "--entry") == 0) {
        const char *s = argv[argi + 1];
        sliced = 1;
        while (*s && n_entry < sizeof entry / sizeof entry[0]) {
            char *end;
            entry[n_entry++] = (size_t)strtoul(s, &end, 10);
            s = *end == ',' ? end + 1 : end;
            if (end == s && *s) break;
        }
        argi += 2;
    }
    char err[512];
    sbt_table *t = reconstruct ? sbt_open_reconstructed(argv[1], 0, err, sizeof err)
                   : sliced    ? sbt_open_slice(argv[1], entry, n_entry, err, sizeof err)
                               : sbt_open(argv[1], err, sizeof err);
    if (!t) {
        fprintf(stderr, "error: %s\n", err);
        return 3;
    }
    const char *dump = NULL;
    if (argi + 1 < argc && strcmp(argv[argi], "--dump") == 0) {
        dump = argv[argi + 1];
        argi += 2;
    }
    size_t na = sbt_num_axes(t), nc = sbt_num_channels(t);
    printf("axes %zu\n", na);
    for (size_t a = 0; a < na; ++a) {
        const double *c = sbt_axis_coords(t, a);
        size_t n = sbt_axis_len(t, a);
        /* %a prints the exact binary value. */
        printf("axis %s %s %zu %a %a %a\n", sbt_axis_name(t, a), sbt_axis_unit(t, a), n, c[0], c[n - 1],
               sbt_axis_period(t, a));
    }
    printf("channels %zu\n", nc);
    for (size_t c = 0; c < nc; ++c) printf("channel %s %s\n", sbt_channel_name(t, c), sbt_channel_unit(t, c));
    printf("values %zu\n", sbt_data_len(t));
    if (dump) {
        FILE *f = fopen(dump, "wb");
        if (!f || fwrite(sbt_data(t), sizeof(float), sbt_data_len(t), f) != sbt_data_len(t)) {
            fprintf(stderr, "error: cannot write %s\n", dump);
            return 4;
        }
        fclose(f);
    }
    if (argi < argc) {
        size_t n = (size_t)(argc - argi);
        double *coords = malloc(n * sizeof *coords), *out = malloc((nc ? nc : 1) * sizeof *out);
        for (size_t i = 0; i < n; ++i) coords[i] = strtod(argv[argi + i], NULL);
        if (sbt_sample(t, coords, n, out, nc) != 0) {
            fprintf(stderr, "error: bad lookup coordinates\n");
            return 5;
        }
        for (size_t c = 0; c < nc; ++c) printf("sample %s %a\n", sbt_channel_name(t, c), out[c]);
        free(coords);
        free(out);
    }
    long p = sbt_channel_index(t, "phase");
    if (p >= 0) printf("has phase channel at index %ld\n", p);
    sbt_close(t);
    return 0;
}
