/* Evaluates an .sbrdf file from C through include/sbrdf.h and prints one line per query:
 *   theta_i phi_i theta_o phi_o wavelength value
 * then checks that sbrdf_eval_batch gives the same values, that sampled directions carry
 * sbrdf_pdf's density and that a junk buffer is refused with an error code.
 *
 *   cargo build --release --lib
 *   cc examples/c/eval.c -Iinclude target/release/libsbrdf.a -lpthread -ldl -lm -o eval_c
 *   ./eval_c samples/golden/ggx_3inc_default.sbrdf
 */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "sbrdf.h"

static void dir(float theta_deg, float phi_deg, float v[3]) {
    const float d = 3.14159265358979f / 180.0f;
    v[0] = sinf(theta_deg * d) * cosf(phi_deg * d);
    v[1] = sinf(theta_deg * d) * sinf(phi_deg * d);
    v[2] = cosf(theta_deg * d);
}

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: %s FILE.sbrdf\n", argv[0]);
        return 2;
    }
    sbrdf_t *b = NULL;
    int rc = sbrdf_open_file(argv[1], &b);
    if (rc != SBRDF_OK) {
        fprintf(stderr, "%s: %s\n", argv[1], sbrdf_error_message(rc));
        return 1;
    }
    const float queries[][4] = {
        {0, 0, 10, 180}, {15, 0, 15, 180}, {30, 0, 35, 170}, {40, 0, 40, 180},
        {45, 90, 45, 270}, {60, 0, 20, 30}, {70, 0, 75, 180}, {25, 200, 60, 10},
    };
    const float wl[3] = {450.0f, 550.0f, 650.0f};
    float out[3];
    for (size_t q = 0; q < sizeof queries / sizeof queries[0]; q++) {
        float wi[3], wo[3];
        dir(queries[q][0], queries[q][1], wi);
        dir(queries[q][2], queries[q][3], wo);
        rc = sbrdf_eval(b, wi, wo, wl, 3, out);
        if (rc != SBRDF_OK) {
            fprintf(stderr, "eval: %s\n", sbrdf_error_message(rc));
            return 1;
        }
        for (int k = 0; k < 3; k++)
            printf("%g %g %g %g %g %.9g\n", queries[q][0], queries[q][1], queries[q][2],
                   queries[q][3], wl[k], out[k]);
    }

    /* The batch entry point on the same queries (packed, stride 3) gives the same values bit for
     * bit; with stride 0 one incident direction serves every pair. */
    {
        enum { N = sizeof queries / sizeof queries[0] };
        float wi[3 * N], wo[3 * N], batch[3 * N], one[3];
        for (size_t q = 0; q < N; q++) {
            dir(queries[q][0], queries[q][1], wi + 3 * q);
            dir(queries[q][2], queries[q][3], wo + 3 * q);
        }
        rc = sbrdf_eval_batch(b, N, wi, 3, wo, 3, wl, 3, batch);
        if (rc != SBRDF_OK) {
            fprintf(stderr, "eval_batch: %s\n", sbrdf_error_message(rc));
            return 1;
        }
        for (size_t q = 0; q < N; q++) {
            sbrdf_eval(b, wi + 3 * q, wo + 3 * q, wl, 3, one);
            if (memcmp(one, batch + 3 * q, sizeof one) != 0) {
                fprintf(stderr, "eval_batch differs from eval at query %zu\n", q);
                return 1;
            }
        }
        rc = sbrdf_eval_batch(b, N, wi, 0, wo, 3, wl, 3, batch);
        for (size_t q = 0; q < N && rc == SBRDF_OK; q++) {
            sbrdf_eval(b, wi, wo + 3 * q, wl, 3, one);
            if (memcmp(one, batch + 3 * q, sizeof one) != 0) rc = SBRDF_ERR_INTERNAL;
        }
        if (rc != SBRDF_OK) {
            fprintf(stderr, "eval_batch with a shared incident direction differs from eval\n");
            return 1;
        }
        fprintf(stderr, "eval_batch: %d pairs, bit for bit as eval (packed and stride 0)\n", (int)N);
    }

    /* Importance sampling: every drawn direction lies above the horizon and carries exactly the
     * density sbrdf_pdf gives it (reported on stderr: stdout is compared with sbrdf eval). */
    for (int s = 0; s < 64; s++) {
        float wi[3], wo[3], p, q;
        dir(30.0f, 20.0f, wi);
        rc = sbrdf_sample(b, wi, (s + 0.5f) / 64.0f, (float)((s * 37) % 64) / 64.0f, wo, &p);
        if (rc != SBRDF_OK || !(p > 0.0f) || wo[2] < 0.0f) {
            fprintf(stderr, "sample %d: %s, pdf %g, wo.z %g\n", s, sbrdf_error_message(rc), p,
                    wo[2]);
            return 1;
        }
        if (sbrdf_pdf(b, wi, wo, &q) != SBRDF_OK || fabsf(p - q) > 1e-6f * q) {
            fprintf(stderr, "sample %d: pdf %g but sbrdf_pdf %g\n", s, p, q);
            return 1;
        }
    }
    fprintf(stderr, "64 samples drawn, each with the density sbrdf_pdf gives it\n");
    sbrdf_close(b);

    /* Hostile input: junk bytes and NULL pointers give error codes, not crashes. */
    unsigned char junk[64];
    for (int i = 0; i < 64; i++) junk[i] = (unsigned char)(i * 37 + 11);
    sbrdf_t *j = NULL;
    rc = sbrdf_open_memory(junk, sizeof junk, &j);
    if (rc == SBRDF_OK || j != NULL) {
        fprintf(stderr, "junk buffer accepted\n");
        return 1;
    }
    fprintf(stderr, "junk buffer refused: %s\n", sbrdf_error_message(rc));
    if (sbrdf_eval(NULL, NULL, NULL, NULL, 0, NULL) != SBRDF_ERR_NULL) return 1;
    sbrdf_close(NULL);
    return 0;
}
