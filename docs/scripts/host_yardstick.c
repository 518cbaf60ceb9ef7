/*
 * A plain C project-and-gather loop: the yardstick issue 4 gives for the machine ("about 240 M
 * voxel-projections per second on this machine with both cores"). It measures the host, not
 * aibr: run it beside `voxel_coloring/128` to tell a slower host from a slower kernel.
 *
 * The work is the bench's: the `lambertian` grid (x, y -0.07..0.07 m, z -0.005..0.2 m, 128
 * voxels along z: 88 x 88 x 128) and 48 cameras of the catalogue rig (640x480, fx = fy = 900,
 * 0.55 m from the axis, 0.32 m up, looking at the axis 0.09 m up, pans spread over
 * +-159 degrees). For every voxel, in every view: project its centre (a 3x4 matrix, in
 * float), divide, round, test the bounds, load the RGB pixel and add it to the voxel's sums.
 * The images are random bytes. Two threads split the layers.
 *
 *   gcc -O2 -pthread -o /tmp/host_yardstick docs/scripts/host_yardstick.c -lm
 *   /tmp/host_yardstick [runs]     # default 15 runs; prints each and the median
 *
 * The figure depends on how the loop is written (the issue does not give its loop), so it is
 * a measure of one host against itself on different days, and only roughly of this host
 * against the issue's.
 */
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define VIEWS 48
#define W 640
#define H 480
#define NX 88
#define NY 88
#define NZ 128
#define THREADS 2

static float P[VIEWS][12];
static uint8_t *images[VIEWS];
static uint64_t checksum[THREADS];

static void camera(int v, double pan) {
    /* Camera centre on the ring, in the turntable frame (z up), looking at the axis. */
    double c[3] = {0.55 * cos(pan), 0.55 * sin(pan), 0.32};
    double t[3] = {0.0, 0.0, 0.09};
    double z[3] = {t[0] - c[0], t[1] - c[1], t[2] - c[2]};
    double n = sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2]);
    for (int i = 0; i < 3; i++) z[i] /= n;
    /* x = z cross up (image right), y = z cross x (image down). */
    double up[3] = {0, 0, 1};
    double x[3] = {z[1] * up[2] - z[2] * up[1], z[2] * up[0] - z[0] * up[2],
                   z[0] * up[1] - z[1] * up[0]};
    n = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    for (int i = 0; i < 3; i++) x[i] /= n;
    double y[3] = {z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2],
                   z[0] * x[1] - z[1] * x[0]};
    double *rows[3] = {x, y, z};
    double k[3][3] = {{900, 0, 319.5}, {0, 900, 239.5}, {0, 0, 1}};
    for (int r = 0; r < 3; r++) {
        for (int col = 0; col < 3; col++) {
            double s = 0;
            for (int m = 0; m < 3; m++) s += k[r][m] * rows[m][col];
            P[v][r * 4 + col] = (float)s;
        }
        double tr = 0;
        for (int m = 0; m < 3; m++) {
            double rc = rows[m][0] * c[0] + rows[m][1] * c[1] + rows[m][2] * c[2];
            tr -= k[r][m] * rc;
        }
        P[v][r * 4 + 3] = (float)tr;
    }
}

static void *work(void *arg) {
    int t = (int)(intptr_t)arg;
    const float x0 = -0.07f, y0 = -0.07f, z0 = -0.005f, s = 0.205f / NZ;
    uint64_t check = 0;
    for (int kz = t; kz < NZ; kz += THREADS) {
        for (int j = 0; j < NY; j++) {
            for (int i = 0; i < NX; i++) {
                float X = x0 + (i + 0.5f) * s, Y = y0 + (j + 0.5f) * s, Z = z0 + (kz + 0.5f) * s;
                uint32_t sum[3] = {0, 0, 0}, count = 0;
                for (int v = 0; v < VIEWS; v++) {
                    const float *p = P[v];
                    float w = p[8] * X + p[9] * Y + p[10] * Z + p[11];
                    if (w <= 0) continue;
                    float u = (p[0] * X + p[1] * Y + p[2] * Z + p[3]) / w;
                    float q = (p[4] * X + p[5] * Y + p[6] * Z + p[7]) / w;
                    int pu = (int)lrintf(u), pv = (int)lrintf(q);
                    if (pu < 0 || pv < 0 || pu >= W || pv >= H) continue;
                    const uint8_t *px = images[v] + 3 * ((size_t)pv * W + pu);
                    sum[0] += px[0];
                    sum[1] += px[1];
                    sum[2] += px[2];
                    count++;
                }
                check += sum[0] + sum[1] + sum[2] + count;
            }
        }
    }
    checksum[t] = check;
    return NULL;
}

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static int by_value(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    int runs = argc > 1 ? atoi(argv[1]) : 15;
    if (runs < 1 || runs > 1000) {
        fprintf(stderr, "runs must be 1 to 1000, got %s\n", argv[1]);
        return 2;
    }
    const double pi = 3.14159265358979323846, range = 159.0 * pi / 180.0;
    uint32_t seed = 1;
    for (int v = 0; v < VIEWS; v++) {
        camera(v, -range + 2.0 * range * v / (VIEWS - 1));
        images[v] = malloc((size_t)W * H * 3);
        if (!images[v]) {
            fprintf(stderr, "out of memory\n");
            return 1;
        }
        for (size_t b = 0; b < (size_t)W * H * 3; b++) {
            seed = seed * 1664525u + 1013904223u;
            images[v][b] = (uint8_t)(seed >> 24);
        }
    }
    double projections = (double)NX * NY * NZ * VIEWS;
    double *ms = malloc(sizeof(double) * runs);
    uint64_t check = 0;
    for (int r = 0; r < runs; r++) {
        pthread_t th[THREADS];
        double start = now();
        for (int t = 0; t < THREADS; t++) pthread_create(&th[t], NULL, work, (void *)(intptr_t)t);
        for (int t = 0; t < THREADS; t++) pthread_join(th[t], NULL);
        ms[r] = (now() - start) * 1e3;
        check = checksum[0] + checksum[1];
        printf("run %2d: %7.1f ms, %6.1f M voxel-projections/s\n", r + 1, ms[r],
               projections / ms[r] / 1e3);
    }
    qsort(ms, runs, sizeof(double), by_value);
    double median = ms[runs / 2];
    printf("median of %d: %.1f ms, %.1f M voxel-projections/s (%.0f projections, checksum %llu)\n",
           runs, median, projections / median / 1e3, projections, (unsigned long long)check);
    return 0;
}
