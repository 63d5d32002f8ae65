/* Shared by the light/ tests: tests/check.h and a few vector helpers. */
#ifndef PL_TESTS_LIGHT_TEST_H
#define PL_TESTS_LIGHT_TEST_H

#include <math.h>
#include <stdio.h>

#include "tests/check.h"

static inline void unit3(float v[3])
{
    double n = sqrt((double)v[0] * v[0] + (double)v[1] * v[1] + (double)v[2] * v[2]);
    for (int k = 0; k < 3; k++)
        v[k] = (float)(v[k] / n);
}

/* An orthonormal frame (e1, e2) perpendicular to unit l. */
static inline void frame3(const double l[3], double e1[3], double e2[3])
{
    double a[3] = {0, 0, 0};
    a[fabs(l[0]) < 0.9 ? 0 : 1] = 1;
    double d = a[0] * l[0] + a[1] * l[1] + a[2] * l[2];
    for (int k = 0; k < 3; k++)
        e1[k] = a[k] - d * l[k];
    double n = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    for (int k = 0; k < 3; k++)
        e1[k] /= n;
    e2[0] = l[1] * e1[2] - l[2] * e1[1];
    e2[1] = l[2] * e1[0] - l[0] * e1[2];
    e2[2] = l[0] * e1[1] - l[1] * e1[0];
}

#endif
