/* The compiled haptic core: the analytic primitives, the god-object and the contact gate.
 *
 * A transcription of primitives.py, vec.py (project_halfspaces), god_object.py and
 * contact_gate.py, which stay the readable reference: every function below names its Python
 * twin and does the same floating-point operations in the same order, so the results are the
 * reference's (the property tests in tests/haptics/test_compiled.py compare them). Built with
 * -ffp-contract=off and without -ffast-math: a fused multiply-add or a reassociated sum would
 * round differently from Python's doubles.
 *
 * Added over the reference, results unchanged: a broad phase. Each bounded body has a bounding
 * ball (centre c, radius rho), and |p - c| - rho is a 1-Lipschitz lower bound of its signed
 * distance everywhere (docs/haptics.md "Compiled core"). The reference evaluates every body at
 * the proxy each tick; here a body is evaluated only when its bound cannot decide the reference's
 * test, so the decisions (and the numbers) are the reference's. A candidate list of the bodies
 * near a reference point, with the smallest bound of all the others, lets a tick skip the far
 * bodies without looking at them.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>
#include <math.h>
#include <string.h>

#define CORE_VERSION 1

/* primitives.py */
#define EPS_SURFACE 1e-10
#define NEWTON_TOL 1e-13
#define SLOPE_TOL 1e-12
#define FEATURE_TOL 1e-12
#define APEX_TOL 1e-9
#define MAX_NEWTON 40
/* vec.py */
#define FEAS_TOL 1e-12
#define PARALLEL_TOL 1e-10
#define TRIPLE_TOL 1e-8
/* god_object.py */
#define CONTACT_TOL 1e-9
#define MAX_PLANES 4
#define CULL_MARGIN 1e-9
#define SHORTCUT_COS 0.5
#define SHORTCUT_MIN 1e-10
#define PARALLEL (1.0 - 1e-15)
#define GLUE_DOT (-1.0 + 1e-9)
#define PUSH_STEPS 3
#define EXIT_REACH 1e3

/* broad phase */
#define LIST_WIDTH 0.15   /* candidate list: bodies whose bound is within this of the nearest */
#define LIST_SLACK 0.05   /* rebuilt once the start point moves this far from where it was built */

enum { SPHERE, BOX, CYLINDER, CONE, PLANE, HEMISPHERE, NSHAPES };

typedef struct { double x, y, z; } V3;
typedef struct { double s, x, y, z; } Ev;  /* (sd, nx, ny, nz) */

typedef struct {
    int type;
    double p[6];       /* sphere R | box hx hy hz | cyl R hh | cone R H L L2 nr nz | plane hx hy | hemi R */
    double ox, oy, oz;
    int rot;
    double m[9];
    double k, mus, mud;
    int bounded;
    double cx, cy, cz, rho;  /* bounding ball (scene frame), rho inflated against rounding */
    PyObject *obj, *id;      /* borrowed: the scene holds the body list */
} CBody;

static inline double dmax(double a, double b) { return b > a ? b : a; }  /* Python max(a, b) */
static inline double dmin(double a, double b) { return b < a ? b : a; }  /* Python min(a, b) */

/* ---------------------------------------------------------------- shapes (local frame) ---- */

static inline void radial(double x, double y, double *rho, double *ux, double *uy)
{
    double r = sqrt(x * x + y * y);
    if (r > 0.0) { *rho = r; *ux = x / r; *uy = y / r; }
    else { *rho = 0.0; *ux = 1.0; *uy = 0.0; }
}

static inline Ev box_eval(double qx, double qy, double qz, double x, double y, double z)
{
    Ev e;
    if (qx > 0.0 || qy > 0.0 || qz > 0.0) {
        double dx = qx > 0.0 ? qx : 0.0, dy = qy > 0.0 ? qy : 0.0, dz = qz > 0.0 ? qz : 0.0;
        double d = sqrt(dx * dx + dy * dy + dz * dz);
        if (d > 0.0) {
            e.s = d; e.x = (x >= 0.0 ? dx : -dx) / d; e.y = (y >= 0.0 ? dy : -dy) / d;
            e.z = (z >= 0.0 ? dz : -dz) / d;
            return e;
        }
    }
    if (qz >= qx && qz >= qy) { e.s = qz; e.x = 0.0; e.y = 0.0; e.z = z >= 0.0 ? 1.0 : -1.0; return e; }
    if (qx >= qy) { e.s = qx; e.x = x >= 0.0 ? 1.0 : -1.0; e.y = 0.0; e.z = 0.0; return e; }
    e.s = qy; e.x = 0.0; e.y = y >= 0.0 ? 1.0 : -1.0; e.z = 0.0;
    return e;
}

static int box_features(double qx, double qy, double qz, double x, double y, double z, V3 *out)
{
    double m = dmax(dmax(qx, qy), qz);
    double thr = (m < 0.0 ? m : 0.0) - FEATURE_TOL;
    int n = 0;
    if (qx >= thr) { out[n].x = x >= 0.0 ? 1.0 : -1.0; out[n].y = 0.0; out[n].z = 0.0; n++; }
    if (qy >= thr) { out[n].x = 0.0; out[n].y = y >= 0.0 ? 1.0 : -1.0; out[n].z = 0.0; n++; }
    if (qz >= thr) { out[n].x = 0.0; out[n].y = 0.0; out[n].z = z >= 0.0 ? 1.0 : -1.0; n++; }
    return n;
}

static Ev shape_eval(const CBody *b, double x, double y, double z)
{
    const double *p = b->p;
    Ev e;
    switch (b->type) {
    case SPHERE: {
        double r2 = x * x + y * y + z * z;
        if (r2 > 0.0) {
            double r = sqrt(r2);
            e.s = r - p[0]; e.x = x / r; e.y = y / r; e.z = z / r;
            return e;
        }
        e.s = -p[0]; e.x = 0.0; e.y = 0.0; e.z = 1.0;
        return e;
    }
    case BOX:
        return box_eval(fabs(x) - p[0], fabs(y) - p[1], fabs(z) - p[2], x, y, z);
    case PLANE:
        return box_eval(fabs(x) - p[0], fabs(y) - p[1], z, x, y, 1.0);
    case CYLINDER: {
        double rho, ux, uy;
        radial(x, y, &rho, &ux, &uy);
        double u = rho - p[0], zc = z - p[1];
        double sz = zc >= 0.0 ? 1.0 : -1.0;
        double w = sz * zc - p[1];
        if (u > 0.0 || w > 0.0) {
            double du = u > 0.0 ? u : 0.0, dw = w > 0.0 ? w : 0.0;
            double d = sqrt(du * du + dw * dw);
            if (d > 0.0) {
                double g = du / d;
                e.s = d; e.x = g * ux; e.y = g * uy; e.z = sz * dw / d;
                return e;
            }
        }
        if (w >= u) { e.s = w; e.x = 0.0; e.y = 0.0; e.z = sz; return e; }
        e.s = u; e.x = ux; e.y = uy; e.z = 0.0;
        return e;
    }
    case CONE: {
        double R = p[0], H = p[1], L = p[2], L2 = p[3], nr = p[4], nz = p[5];
        double rho, ux, uy;
        radial(x, y, &rho, &ux, &uy);
        double s_line = (H * rho + R * z - R * H) / L;
        if (z >= 0.0 && s_line <= 0.0) {
            if (z <= -s_line) { e.s = -z; e.x = 0.0; e.y = 0.0; e.z = -1.0; return e; }
            if (rho == 0.0 && z >= H) { e.s = 0.0; e.x = 0.0; e.y = 0.0; e.z = 1.0; return e; }
            e.s = s_line; e.x = nr * ux; e.y = nr * uy; e.z = nz;
            return e;
        }
        if (z < 0.0 && rho <= R) { e.s = -z; e.x = 0.0; e.y = 0.0; e.z = -1.0; return e; }
        double sn = (R - rho) * R + z * H, dr, dz;
        if (sn <= 0.0) { dr = rho - R; dz = z; }
        else if (sn >= L2) { dr = rho; dz = z - H; }
        else { e.s = s_line; e.x = nr * ux; e.y = nr * uy; e.z = nz; return e; }
        double d = sqrt(dr * dr + dz * dz);
        if (d > 0.0) { e.s = d; e.x = dr / d * ux; e.y = dr / d * uy; e.z = dz / d; return e; }
        e.s = 0.0; e.x = nr * ux; e.y = nr * uy; e.z = nz;
        return e;
    }
    default: { /* HEMISPHERE */
        double R = p[0];
        if (z < 0.0) {
            double rho2 = x * x + y * y;
            if (rho2 <= R * R) { e.s = -z; e.x = 0.0; e.y = 0.0; e.z = -1.0; return e; }
            double rho = sqrt(rho2), dr = rho - R;
            double d = sqrt(dr * dr + z * z);
            double g = dr / (d * rho);
            e.s = d; e.x = g * x; e.y = g * y; e.z = z / d;
            return e;
        }
        double r = sqrt(x * x + y * y + z * z);
        if (r > R || z > R - r) { e.s = r - R; e.x = x / r; e.y = y / r; e.z = z / r; return e; }
        e.s = -z; e.x = 0.0; e.y = 0.0; e.z = -1.0;
        return e;
    }
    }
}

/* _Shape._features and the overrides; out holds up to 3 normals */
static int shape_features(const CBody *b, double x, double y, double z, double dx, double dy, V3 *out)
{
    const double *p = b->p;
    switch (b->type) {
    case SPHERE: {
        Ev e = shape_eval(b, x, y, z);
        out[0].x = e.x; out[0].y = e.y; out[0].z = e.z;
        return 1;
    }
    case BOX:
        return box_features(fabs(x) - p[0], fabs(y) - p[1], fabs(z) - p[2], x, y, z, out);
    case PLANE:
        return box_features(fabs(x) - p[0], fabs(y) - p[1], z, x, y, 1.0, out);
    case CYLINDER: {
        double rho, ux, uy;
        radial(x, y, &rho, &ux, &uy);
        double u = rho - p[0], zc = z - p[1];
        double sz = zc >= 0.0 ? 1.0 : -1.0;
        double w = sz * zc - p[1];
        double m = dmax(u, w);
        double thr = (m < 0.0 ? m : 0.0) - FEATURE_TOL;
        int n = 0;
        if (w >= thr) { out[n].x = 0.0; out[n].y = 0.0; out[n].z = sz; n++; }
        if (u >= thr) { out[n].x = ux; out[n].y = uy; out[n].z = 0.0; n++; }
        return n;
    }
    case CONE: {
        double R = p[0], H = p[1], L = p[2], nr = p[4], nz = p[5];
        double rho, ux, uy;
        radial(x, y, &rho, &ux, &uy);
        double s_line = (H * rho + R * z - R * H) / L;
        double m = dmax(-z, s_line);
        double thr = (m < 0.0 ? m : 0.0) - FEATURE_TOL;
        int n = 0;
        if (-z >= thr) { out[n].x = 0.0; out[n].y = 0.0; out[n].z = -1.0; n++; }
        if (s_line >= thr) {
            if (rho * rho + (z - H) * (z - H) <= APEX_TOL * APEX_TOL) {
                double dl = sqrt(dx * dx + dy * dy);
                if (dl > 0.0) { ux = dx / dl; uy = dy / dl; }
            }
            out[n].x = nr * ux; out[n].y = nr * uy; out[n].z = nz; n++;
        }
        return n;
    }
    default: { /* HEMISPHERE */
        double r = sqrt(x * x + y * y + z * z);
        double m = dmax(r - p[0], -z);
        double thr = (m < 0.0 ? m : 0.0) - FEATURE_TOL;
        int n = 0;
        if (-z >= thr) { out[n].x = 0.0; out[n].y = 0.0; out[n].z = -1.0; n++; }
        if (r - p[0] >= thr && r > 0.0) { out[n].x = x / r; out[n].y = y / r; out[n].z = z / r; n++; }
        return n;
    }
    }
}

/* ------------------------------------------------------------------- bodies (scene frame) -- */

static Ev body_eval(const CBody *b, V3 q)  /* Body._eval */
{
    double x = q.x - b->ox, y = q.y - b->oy, z = q.z - b->oz;
    if (!b->rot)
        return shape_eval(b, x, y, z);
    const double *m = b->m;
    Ev l = shape_eval(b, m[0] * x + m[3] * y + m[6] * z, m[1] * x + m[4] * y + m[7] * z,
                      m[2] * x + m[5] * y + m[8] * z), e;
    e.s = l.s;
    e.x = m[0] * l.x + m[1] * l.y + m[2] * l.z;
    e.y = m[3] * l.x + m[4] * l.y + m[5] * l.z;
    e.z = m[6] * l.x + m[7] * l.y + m[8] * l.z;
    return e;
}

static int body_features(const CBody *b, V3 a, double dx, double dy, double dz, V3 *out)  /* Body._features */
{
    double x = a.x - b->ox, y = a.y - b->oy, z = a.z - b->oz;
    if (!b->rot)
        return shape_features(b, x, y, z, dx, dy, out);
    const double *m = b->m;
    int n = shape_features(b, m[0] * x + m[3] * y + m[6] * z, m[1] * x + m[4] * y + m[7] * z,
                           m[2] * x + m[5] * y + m[8] * z,
                           m[0] * dx + m[3] * dy + m[6] * dz, m[1] * dx + m[4] * dy + m[7] * dz, out);
    for (int i = 0; i < n; i++) {
        V3 l = out[i];
        out[i].x = m[0] * l.x + m[1] * l.y + m[2] * l.z;
        out[i].y = m[3] * l.x + m[4] * l.y + m[5] * l.z;
        out[i].z = m[6] * l.x + m[7] * l.y + m[8] * l.z;
    }
    return n;
}

typedef struct { double t; V3 p; Ev ev; } Hit;

static inline int v3_eq(V3 a, double x, double y, double z) { return a.x == x && a.y == y && a.z == z; }

/* Body._cast: 1 and *h on a hit (2: the hit point is a itself), 0 for None. feats/nf: the glued-filtered features, nf < 0 = None. */
static int body_cast(const CBody *b, V3 a, double dx, double dy, double dz, double radius, double t_max,
                     const Ev *ev0, const V3 *feats, int nf, Hit *h)
{
    Ev ev = ev0 ? *ev0 : body_eval(b, a);
    double f = ev.s - radius;
    if (f <= -EPS_SURFACE) { h->t = 0.0; h->p = a; h->ev = ev; return 2; }
    double g = ev.x * dx + ev.y * dy + ev.z * dz;
    if (f <= EPS_SURFACE) {
        double thr = -(SLOPE_TOL * sqrt(dx * dx + dy * dy + dz * dz) + NEWTON_TOL);
        if (g >= thr && nf < 0)
            return 0;
        if (radius == 0.0) {
            int glued = nf >= 0;
            V3 own[3];
            if (!glued) { nf = body_features(b, a, dx, dy, dz, own); feats = own; }
            if (nf == 0) return 0;
            double smax = 0.0, smin = 0.0; int imin = 0;
            for (int i = 0; i < nf; i++) {
                double s = feats[i].x * dx + feats[i].y * dy + feats[i].z * dz;
                if (i == 0 || s > smax) smax = s;
                if (i == 0 || s < smin) { smin = s; imin = i; }
            }
            if (smax >= thr) return 0;
            if (f <= NEWTON_TOL) {
                int in_feats = 0;
                if (glued)
                    for (int i = 0; i < nf; i++) in_feats |= v3_eq(feats[i], ev.x, ev.y, ev.z);
                h->t = 0.0; h->p = a;
                if (g < 0.0 && (!glued || in_feats)) { h->ev = ev; return 2; }
                h->ev.s = ev.s; h->ev.x = feats[imin].x; h->ev.y = feats[imin].y; h->ev.z = feats[imin].z;
                return 2;
            }
        } else if (g >= thr) {
            return 0;
        } else if (f <= NEWTON_TOL) {
            h->t = 0.0; h->p = a; h->ev = ev; return 2;
        }
    }
    double t = 0.0;
    V3 p = a;
    for (int it = 0; it < MAX_NEWTON; it++) {
        if (g >= 0.0) return 0;
        t -= f / g;
        if (t > t_max) return 0;
        p.x = a.x + t * dx; p.y = a.y + t * dy; p.z = a.z + t * dz;
        Ev prev = ev;
        ev = body_eval(b, p);
        f = ev.s - radius;
        if (f <= NEWTON_TOL) {
            if (ev.x * dx + ev.y * dy + ev.z * dz >= 0.0) { ev.x = prev.x; ev.y = prev.y; ev.z = prev.z; }
            h->t = t; h->p = p; h->ev = ev; return 1;
        }
        g = ev.x * dx + ev.y * dy + ev.z * dz;
    }
    h->t = t; h->p = p; h->ev = ev;
    return 1;
}

/* ---------------------------------------------------------------- vec.project_halfspaces -- */

typedef struct { double x, y, z, c; } Plane4;

static int three_planes(const Plane4 *p1, const Plane4 *p2, const Plane4 *p3, V3 *out)
{
    double ux = p2->y * p3->z - p2->z * p3->y, uy = p2->z * p3->x - p2->x * p3->z, uz = p2->x * p3->y - p2->y * p3->x;
    double vx = p3->y * p1->z - p3->z * p1->y, vy = p3->z * p1->x - p3->x * p1->z, vz = p3->x * p1->y - p3->y * p1->x;
    double wx = p1->y * p2->z - p1->z * p2->y, wy = p1->z * p2->x - p1->x * p2->z, wz = p1->x * p2->y - p1->y * p2->x;
    double det = p1->x * ux + p1->y * uy + p1->z * uz;
    if (fabs(det) < TRIPLE_TOL) return 0;
    double s = 1.0 / det;
    out->x = (ux * p1->c + vx * p2->c + wx * p3->c) * s;
    out->y = (uy * p1->c + vy * p2->c + wy * p3->c) * s;
    out->z = (uz * p1->c + vz * p2->c + wz * p3->c) * s;
    return 1;
}

static int feasible(const Plane4 *pl, int m, V3 t)
{
    for (int i = 0; i < m; i++)
        if (!(pl[i].x * t.x + pl[i].y * t.y + pl[i].z * t.z - pl[i].c >= -FEAS_TOL)) return 0;
    return 1;
}

static int project_halfspaces(V3 h, const Plane4 *pl, int m, V3 *out)
{
    double hx = h.x, hy = h.y, hz = h.z;
    if (m == 1) {
        double s = pl[0].x * hx + pl[0].y * hy + pl[0].z * hz - pl[0].c;
        if (s >= 0.0) *out = h;
        else { out->x = hx - s * pl[0].x; out->y = hy - s * pl[0].y; out->z = hz - s * pl[0].z; }
        return 1;
    }
    double viol[MAX_PLANES], vmin = 0.0;
    for (int i = 0; i < m; i++) {
        viol[i] = pl[i].x * hx + pl[i].y * hy + pl[i].z * hz - pl[i].c;
        if (i == 0 || viol[i] < vmin) vmin = viol[i];
    }
    if (vmin >= -FEAS_TOL) { *out = h; return 1; }
    int found = 0;
    double best_d2 = INFINITY;
    V3 best = h, t;
    for (int i = 0; i < m; i++) {
        double s = viol[i], nx = pl[i].x, ny = pl[i].y, nz = pl[i].z;
        if (s < 0.0 && s * s < best_d2) {
            t.x = hx - s * nx; t.y = hy - s * ny; t.z = hz - s * nz;
            if (feasible(pl, m, t)) { best = t; best_d2 = s * s; found = 1; }
        }
        for (int j = i + 1; j < m; j++) {
            double bx = pl[j].x, by = pl[j].y, bz = pl[j].z;
            double g = nx * bx + ny * by + nz * bz;
            double det = 1.0 - g * g;
            if (det < PARALLEL_TOL) continue;
            double p = (viol[i] - g * viol[j]) / det, q = (viol[j] - g * viol[i]) / det;
            double ox = p * nx + q * bx, oy = p * ny + q * by, oz = p * nz + q * bz;
            double d2 = ox * ox + oy * oy + oz * oz;
            if (d2 < best_d2) {
                t.x = hx - ox; t.y = hy - oy; t.z = hz - oz;
                if (feasible(pl, m, t)) { best = t; best_d2 = d2; found = 1; }
            }
            for (int k = j + 1; k < m; k++) {
                if (three_planes(&pl[i], &pl[j], &pl[k], &t)) {
                    double ex = t.x - hx, ey = t.y - hy, ez = t.z - hz;
                    double dd = ex * ex + ey * ey + ez * ez;
                    if (dd < best_d2 && feasible(pl, m, t)) { best = t; best_d2 = dd; found = 1; }
                }
            }
        }
    }
    *out = best;
    return found;
}

/* ----------------------------------------------------------------------- the god-object ---- */

static PyObject *BodyType, *ProxyStepType, *ContactType, *ShapeTypes[NSHAPES];
static PyObject *s_proxy, *s_force, *s_contacts, *s_separation, *s_iterations;
static PyObject *s_body_id, *s_normal, *s_depth, *s_point, *empty_tuple, *zero_vec;

typedef struct {
    PyObject_HEAD
    double radius, tolerance;
    int max_iterations;
    char use_shortcut, broad;    /* broad: skip far bodies by their bounding balls (results unchanged) */
    int has_proxy, sticking;
    V3 proxy;
    PyObject *friction_body;     /* id of the one body touched last tick, or NULL */
    /* the scene: the body list it was built from (strong refs), its bodies, scratch */
    PyObject **objs;
    PyObject *scene_tuple;       /* the body tuple the scene was built from, if a tuple (immutable) */
    CBody *B;
    int n, cap;
    int *all, *cand, ncand, list_valid;
    V3 ref;
    double lout;                 /* lower bound of sd at ref of every body not in cand */
    Ev *ev0, *evs;
    unsigned char *in_cand;
    unsigned *seen, gen;         /* ev0[i] holds body i's eval at the tick's start when seen[i] == gen */
    int *idx, *idx2;
    struct Touch *tbuf;          /* the touching bodies, twice (the friction step's second look) */
} GodCore;

typedef struct {
    GodCore *g;
    const CBody *B;
    int n;
    double r;
    V3 start;
    double lout_s;  /* lower bound of sd at start of the bodies not in cand */
} Tick;

static inline double norm3(double x, double y, double z) { return sqrt(x * x + y * y + z * z); }

static inline double bound_at(const CBody *b, V3 q)
{
    if (!b->bounded) return -INFINITY;
    return norm3(q.x - b->cx, q.y - b->cy, q.z - b->cz) - b->rho;
}

/* lower bound of sd at q of every body off the candidate list */
static inline double lout_at(const GodCore *g, V3 q)
{
    if (!g->list_valid) return -INFINITY;
    double d = norm3(q.x - g->ref.x, q.y - g->ref.y, q.z - g->ref.z);
    return g->lout - d - 1e-9 * (1.0 + d);
}

static void tick_at(Tick *T, V3 p)
{
    T->start = p;
    if (++T->g->gen == 0) {  /* wrapped: forget every mark */
        memset(T->g->seen, 0, sizeof(unsigned) * (size_t)T->n);
        T->g->gen = 1;
    }
    T->lout_s = lout_at(T->g, p);
}

static inline Ev ev_start(Tick *T, int i)
{
    GodCore *g = T->g;
    if (g->seen[i] != g->gen) { g->ev0[i] = body_eval(&T->B[i], T->start); g->seen[i] = g->gen; }
    return g->ev0[i];
}

/* the candidate list around p: every body whose bound at p is within LIST_WIDTH of the nearest
 * upper bound (a body's distance is at most |p - c|, c being inside it) */
static void build_list(GodCore *g, V3 p)
{
    double ub2 = INFINITY, ub = INFINITY;
    for (int i = 0; i < g->n; i++) {
        const CBody *b = &g->B[i];
        if (b->bounded) {
            double dx = p.x - b->cx, dy = p.y - b->cy, dz = p.z - b->cz, d2 = dx * dx + dy * dy + dz * dz;
            if (d2 < ub2) ub2 = d2;
        } else {
            double u = body_eval(b, p).s;
            if (u < ub) ub = u;
        }
    }
    ub = dmin(ub, sqrt(ub2));
    /* listed: bound |p - c| - rho <= thr; every other body's bound exceeds thr, so thr is a
     * lower bound of their distances (no square root per body) */
    double thr = ub + LIST_WIDTH;
    g->ncand = 0;
    for (int i = 0; i < g->n; i++) {
        const CBody *b = &g->B[i];
        int in = 1;
        if (b->bounded) {
            double dx = p.x - b->cx, dy = p.y - b->cy, dz = p.z - b->cz, d2 = dx * dx + dy * dy + dz * dz;
            double lim = thr + b->rho;
            in = lim >= 0.0 && d2 <= lim * lim * (1.0 + 1e-12);
        }
        g->in_cand[i] = (unsigned char)in;
        if (in) g->cand[g->ncand++] = i;
    }
    g->ref = p;
    g->lout = thr;
    g->list_valid = 1;
}

static void ensure_list(GodCore *g, V3 p)
{
    if (!g->broad) { g->list_valid = 0; return; }
    if (g->list_valid && norm3(p.x - g->ref.x, p.y - g->ref.y, p.z - g->ref.z) <= LIST_SLACK) return;
    build_list(g, p);
}

/* the bodies to look at for a test that only bodies with a lower bound <= thr can pass */
static inline const int *scan(Tick *T, double lout_minus, double thr, int *nx)
{
    if (T->g->broad && lout_minus > thr) { *nx = T->g->ncand; return T->g->cand; }
    *nx = T->n;
    return T->g->all;
}

/* _unglued_features: fs/un per body of on[] */
static void unglued(const CBody *B, const int *on, int non, V3 a, double dx, double dy, double dz,
                    V3 (*fs)[3], int *fsn, V3 (*un)[3], int *unn)
{
    for (int k = 0; k < non; k++) fsn[k] = body_features(&B[on[k]], a, dx, dy, dz, fs[k]);
    for (int k = 0; k < non; k++) {
        unn[k] = 0;
        for (int q = 0; q < fsn[k]; q++) {
            V3 nn = fs[k][q];
            int keep = 1;
            for (int j = 0; j < non && keep; j++) {
                if (j == k) continue;
                for (int w = 0; w < fsn[j]; w++) {
                    V3 m = fs[j][w];
                    if (!(nn.x * m.x + nn.y * m.y + nn.z * m.z > GLUE_DOT)) { keep = 0; break; }
                }
            }
            if (keep) un[k][unn[k]++] = nn;
        }
        if (unn[k] == 0) {
            for (int q = 0; q < fsn[k]; q++) un[k][q] = fs[k][q];
            unn[k] = fsn[k];
        }
    }
}

typedef struct { Hit h; int i; int is_a; } First;

#define MAX_ON 16  /* bodies whose surface one point lies on; more are treated without glue */

/* _first_hit; a_is_start: a is the tick's start point with known evals (the reference's ``known``) */
static int first_hit(Tick *T, V3 a, V3 b, int known, int ki, const Ev *kev, int skip, First *out)
{
    GodCore *g = T->g;
    const CBody *B = T->B;
    double r = T->r, sx = T->start.x, sy = T->start.y, sz = T->start.z;
    double ax = a.x - sx, ay = a.y - sy, az = a.z - sz;
    double bx = b.x - sx, by = b.y - sy, bz = b.z - sz;
    double ra = ax * ax + ay * ay + az * az, rb = bx * bx + by * by + bz * bz;
    double reach = sqrt(ra > rb ? ra : rb) + CULL_MARGIN;
    int nx, m = 0;
    const int *ix = scan(T, T->lout_s - r, reach, &nx);
    int *idx = g->idx;
    for (int q = 0; q < nx; q++) {
        int i = ix[q];
        if (i == skip) continue;
        if (T->g->broad && B[i].bounded && bound_at(&B[i], T->start) - r > reach) continue;
        if (ev_start(T, i).s - r <= reach) idx[m++] = i;
    }
    if (m == 0) return 0;
    Ev *evs = g->evs;
    for (int q = 0; q < m; q++) {
        int i = idx[q];
        evs[q] = known ? ev_start(T, i) : (i == ki ? *kev : body_eval(&B[i], a));
    }
    double dx = b.x - a.x, dy = b.y - a.y, dz = b.z - a.z;
    int on[MAX_ON], non = 0, has_feats = 0;
    V3 fs[MAX_ON][3], un[MAX_ON][3];
    int fsn[MAX_ON], unn[MAX_ON];
    int featq[MAX_ON];  /* position in idx of each on-body */
    if (r == 0.0 && m > 1) {
        for (int q = 0; q < m; q++)
            if (-EPS_SURFACE < evs[q].s && evs[q].s <= EPS_SURFACE && non < MAX_ON) { featq[non] = q; on[non++] = idx[q]; }
        if (non > 1) { unglued(B, on, non, a, dx, dy, dz, fs, fsn, un, unn); has_feats = 1; }
    }
    int found = 0;
    double t_max = 1.0;
    Hit h;
    for (int q = 0; q < m; q++) {
        int i = idx[q];
        const V3 *feats = NULL;
        int nf = -1;
        if (has_feats)
            for (int k = 0; k < non; k++)
                if (featq[k] == q && unn[k] < fsn[k]) { feats = un[k]; nf = unn[k]; }
        int c = body_cast(&B[i], a, dx, dy, dz, r, t_max, &evs[q], feats, nf, &h);
        if (c && (!found || h.t < out->h.t)) {
            out->h = h;
            out->i = i;
            out->is_a = c == 2;
            found = 1;
            t_max = h.t;
        }
    }
    return found;
}

static const V3 AXES[6] = {{1.0, 0.0, 0.0}, {-1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, -1.0, 0.0},
                           {0.0, 0.0, 1.0}, {0.0, 0.0, -1.0}};

/* _exit_along; 1 and *out, or 0 for None */
static int exit_along(const CBody *B, int n, V3 x, V3 u, double r, V3 *out)
{
    V3 p = x;
    for (int it = 0; it < n + 1; it++) {
        double far_s = 0.0;
        for (int i = 0; i < n; i++) {
            if (body_eval(&B[i], p).s - r > -EPS_SURFACE) continue;
            double dx = -EXIT_REACH * u.x, dy = -EXIT_REACH * u.y, dz = -EXIT_REACH * u.z;
            V3 from = {p.x - dx, p.y - dy, p.z - dz};
            Hit h;
            if (!body_cast(&B[i], from, dx, dy, dz, r, 1.0, NULL, NULL, -1, &h) || h.t == 0.0) return 0;
            far_s = dmax(far_s, EXIT_REACH * (1.0 - h.t));
        }
        if (far_s == 0.0) { *out = p; return 1; }
        p.x = p.x + far_s * u.x; p.y = p.y + far_s * u.y; p.z = p.z + far_s * u.z;
    }
    return 0;
}

/* _push_out: leaves the tick at the pushed-out point (its evals cached lazily) */
static void push_out(Tick *T, V3 x)
{
    const CBody *B = T->B;
    int n = T->n;
    double r = T->r;
    tick_at(T, x);
    int nx, inside = -1, ninside = 0;
    const int *ix = scan(T, T->lout_s - r, -EPS_SURFACE, &nx);
    for (int q = 0; q < nx; q++) {
        int i = ix[q];
        if (T->g->broad && B[i].bounded && bound_at(&B[i], x) - r > -EPS_SURFACE) continue;
        if (ev_start(T, i).s - r <= -EPS_SURFACE) { if (!ninside) inside = i; ninside++; }
    }
    if (!ninside) return;
    if (ninside == 1) {
        V3 y = x;
        Ev ev = ev_start(T, inside);
        for (int s = 0; s < PUSH_STEPS; s++) {
            double f = ev.s - r;
            y.x = y.x - f * ev.x; y.y = y.y - f * ev.y; y.z = y.z - f * ev.z;
            tick_at(T, y);
            int out_all = 1;
            ix = scan(T, T->lout_s - r, -EPS_SURFACE, &nx);
            for (int q = 0; q < nx && out_all; q++) {
                int i = ix[q];
                if (T->g->broad && B[i].bounded && bound_at(&B[i], y) - r > -EPS_SURFACE) continue;
                if (!(ev_start(T, i).s - r > -EPS_SURFACE)) out_all = 0;
            }
            if (out_all) return;
            ev = ev_start(T, inside);
            if (ev.s - r > -EPS_SURFACE) break;
        }
    }
    /* inside several bodies (or out of one into another): the nearest exit along rays */
    V3 best = x;
    double best_d = INFINITY;
    for (int k = 0; k < n + 6; k++) {
        V3 u, y;
        if (k < n) { Ev e = body_eval(&B[k], x); u.x = e.x; u.y = e.y; u.z = e.z; }
        else u = AXES[k - n];
        if (exit_along(B, n, x, u, r, &y)) {
            double d = (y.x - x.x) * (y.x - x.x) + (y.y - x.y) * (y.y - x.y) + (y.z - x.z) * (y.z - x.z);
            if (d < best_d) { best = y; best_d = d; }
        }
    }
    tick_at(T, best);
}

/* GodObject._shortcut; 1 and (*c, *evc) or 0 */
static int shortcut(Tick *T, V3 x, int i, Ev ev_x, V3 hip, int *hip_i, Ev *hip_ev, V3 *c, Ev *evc)
{
    double r = T->r;
    if (*hip_i != i) { *hip_ev = body_eval(&T->B[i], hip); *hip_i = i; }
    Ev ev = *hip_ev;
    double f = ev.s - r;
    double ax = ev_x.x, ay = ev_x.y, az = ev_x.z, bx = ev.x, by = ev.y, bz = ev.z;
    if (f >= 0.0 || ax * bx + ay * by + az * bz < SHORTCUT_COS) return 0;
    V3 cc = {hip.x - f * bx, hip.y - f * by, hip.z - f * bz};
    double vx = cc.x - x.x, vy = cc.y - x.y, vz = cc.z - x.z;
    double va = ax * vx + ay * vy + az * vz;
    double wx = vx - va * ax, wy = vy - va * ay, wz = vz - va * az;
    double den = bx * wx + by * wy + bz * wz;
    First h;
    if (den <= SHORTCUT_MIN * sqrt(wx * wx + wy * wy + wz * wz)) {
        if (first_hit(T, x, cc, 0, i, &ev_x, -1, &h)) return 0;
    } else {
        double beta = (bx * vx + by * vy + bz * vz) / den;
        V3 m = {x.x + beta * wx, x.y + beta * wy, x.z + beta * wz};
        if (first_hit(T, x, m, 0, i, &ev_x, -1, &h) || first_hit(T, m, cc, 0, -1, NULL, i, &h)) return 0;
    }
    *c = cc;
    evc->s = r; evc->x = bx; evc->y = by; evc->z = bz;
    return 1;
}

typedef struct Touch { int i; Ev ev; double depth; } Touch;

/* GodObject._touching over ix[0..nx); known: body ki's eval at x (ki < 0: none). Returns count. */
static int touching(Tick *T, const int *ix, int nx, int ki, const Ev *kev, V3 x, V3 hip, Touch *out,
                    int bound_skip)
{
    const CBody *B = T->B;
    double r = T->r;
    double ex = x.x - hip.x, ey = x.y - hip.y, ez = x.z - hip.z;
    int non = 0;
    for (int q = 0; q < nx; q++) {
        int i = ix[q];
        if (bound_skip && T->g->broad && B[i].bounded && bound_at(&B[i], x) - r > CONTACT_TOL) continue;
        Ev ev = i == ki ? *kev : body_eval(&B[i], x);
        if (fabs(ev.s - r) <= CONTACT_TOL) { out[non].i = i; out[non].ev = ev; non++; }
    }
    if (r == 0.0 && non) {
        int single_parallel = 0;
        if (non == 1) {
            double a = out[0].ev.x * ex + out[0].ev.y * ey + out[0].ev.z * ez;
            single_parallel = a * a >= (ex * ex + ey * ey + ez * ez) * PARALLEL;
        }
        if (!single_parallel && non <= MAX_ON) {
            int on[MAX_ON], fsn[MAX_ON], unn[MAX_ON];
            V3 fs[MAX_ON][3], un[MAX_ON][3];
            for (int k = 0; k < non; k++) on[k] = out[k].i;
            unglued(B, on, non, x, -ex, -ey, -ez, fs, fsn, un, unn);
            for (int k = 0; k < non; k++) {
                V3 nn = {out[k].ev.x, out[k].ev.y, out[k].ev.z};
                int in_fs = 0, in_un = 0;
                for (int q = 0; q < fsn[k]; q++) in_fs |= v3_eq(fs[k][q], nn.x, nn.y, nn.z);
                for (int q = 0; q < unn[k]; q++) in_un |= v3_eq(un[k][q], nn.x, nn.y, nn.z);
                V3 cands[4];
                int nc = 0;
                for (int q = 0; q < unn[k]; q++) cands[nc++] = un[k][q];
                if (!in_fs || in_un) cands[nc++] = nn;
                V3 best = cands[0];
                double bv = best.x * ex + best.y * ey + best.z * ez;
                for (int q = 1; q < nc; q++) {
                    double v = cands[q].x * ex + cands[q].y * ey + cands[q].z * ez;
                    if (v > bv) { bv = v; best = cands[q]; }
                }
                out[k].ev.x = best.x; out[k].ev.y = best.y; out[k].ev.z = best.z;
            }
        }
    }
    int npos = 0;
    for (int k = 0; k < non; k++) {
        out[k].depth = dmax(0.0, out[k].ev.x * ex + out[k].ev.y * ey + out[k].ev.z * ez);
        npos += out[k].depth > 0.0;
    }
    if (npos && npos < non) {
        int w = 0;
        for (int k = 0; k < non; k++) if (out[k].depth > 0.0) out[w++] = out[k];
        non = w;
    }
    return non;
}

/* GodObject._friction: 0 = x unchanged, 1 = moved to *x2 (the reference's ``x2 is not x``) */
static int friction(Tick *T, GodCore *g, int bi, Ev ev_x, V3 x, int x_is_start, V3 hip, V3 *x2)
{
    const CBody *body = &T->B[bi];
    double r = T->r;
    V3 start = T->start;
    Ev ev_s = ev_start(T, bi);
    if (fabs(ev_s.s - r) <= CONTACT_TOL) {
        double fx = start.x - hip.x, fy = start.y - hip.y, fz = start.z - hip.z;
        double fn = ev_s.x * fx + ev_s.y * fy + ev_s.z * fz;
        double ft2 = fx * fx + fy * fy + fz * fz - fn * fn;
        double mu = g->sticking ? body->mus : body->mud;
        double mfn = mu * fn;
        if (fn > 0.0 && ft2 <= mfn * mfn) {
            g->sticking = 1;
            *x2 = start;
            return !x_is_start;
        }
    }
    g->sticking = 0;
    double nx = ev_x.x, ny = ev_x.y, nz = ev_x.z;
    double depth = nx * (x.x - hip.x) + ny * (x.y - hip.y) + nz * (x.z - hip.z);
    double vx = start.x - x.x, vy = start.y - x.y, vz = start.z - x.z;
    double vn = nx * vx + ny * vy + nz * vz;
    vx = vx - vn * nx; vy = vy - vn * ny; vz = vz - vn * nz;
    double lt = sqrt(vx * vx + vy * vy + vz * vz);
    double lag = body->mud * depth;
    if (lag <= 0.0 || lt == 0.0) return 0;
    double s = dmin(lag, lt) / lt;
    V3 cand = {x.x + s * vx, x.y + s * vy, x.z + s * vz};
    First h;
    if (first_hit(T, x, cand, 0, -1, NULL, -1, &h)) {
        *x2 = h.h.p;
        return !h.is_a;
    }
    if (first_hit(T, cand, hip, 0, -1, NULL, -1, &h)) { *x2 = h.h.p; return 1; }
    return 0;
}

static inline Plane4 plane_of(Ev ev, V3 x)  /* _plane */
{
    Plane4 p = {ev.x, ev.y, ev.z, ev.x * x.x + ev.y * x.y + ev.z * x.z};
    return p;
}

typedef struct {
    V3 proxy, force;
    double separation;
    int iterations, ntouch;
    Touch *touch;
} StepOut;

/* GodObject.step on the synced scene */
static void god_step(GodCore *g, V3 hip, StepOut *o, Touch *tbuf)
{
    Tick T = {g, g->B, g->n, g->radius, {0, 0, 0}, 0.0};
    double r = g->radius;
    if (!g->has_proxy) {  /* reset(hip) */
        ensure_list(g, hip);
        push_out(&T, hip);
        g->proxy = T.start; g->has_proxy = 1;
        Py_CLEAR(g->friction_body);
        g->sticking = 0;
    }
    ensure_list(g, g->proxy);
    push_out(&T, g->proxy);
    V3 start = T.start, x = start, last_hit = start;
    int xs = 1, ls = 0;  /* x / last_hit is the start object (the reference compares identities) */
    double tol2 = g->tolerance * g->tolerance;
    int hit_i = -1, free_ = 0, iterations = 0, use_sc = g->use_shortcut, known = 1, capped = 1;
    Ev hit_ev = {0, 0, 0, 0};
    int hip_i = -1;
    Ev hip_ev = {0.0, 0.0, 0.0, 0.0};
    for (int it = 0; it < g->max_iterations; it++) {
        iterations++;
        First h;
        int got = first_hit(&T, x, hip, known, -1, NULL, -1, &h);
        known = 0;
        if (!got) { x = hip; xs = 0; free_ = 1; capped = 0; break; }
        x = h.h.p; xs = h.is_a ? xs : 0; hit_i = h.i; hit_ev = h.h.ev;
        if (use_sc) {
            use_sc = 0;
            V3 c; Ev evc;
            if (shortcut(&T, x, hit_i, hit_ev, hip, &hip_i, &hip_ev, &c, &evc)) { x = c; xs = 0; hit_ev = evc; }
        }
        last_hit = x; ls = xs;
        Plane4 planes[MAX_PLANES];
        int np = 1, converged = 0, slid = 0;
        V3 target;
        planes[0] = plane_of(hit_ev, x);
        for (;;) {
            int ok = project_halfspaces(hip, planes, np, &target);
            if (!ok || ((target.x - x.x) * (target.x - x.x) + (target.y - x.y) * (target.y - x.y)
                        + (target.z - x.z) * (target.z - x.z)) <= tol2) { converged = 1; break; }
            First h2;
            if (!first_hit(&T, x, target, 0, hit_i, &hit_ev, -1, &h2)) { slid = 1; break; }
            x = h2.h.p; xs = h2.is_a ? xs : 0; hit_i = h2.i; hit_ev = h2.h.ev;
            last_hit = x; ls = xs;
            if (np == MAX_PLANES) break;
            planes[np++] = plane_of(hit_ev, x);
        }
        if (converged) { capped = 0; break; }
        if (slid) { x = target; xs = 0; }
    }
    if (capped) { x = last_hit; xs = ls; }

    /* separation: exact sd(hip) only for bodies whose Lipschitz bound can be the minimum */
    double hx = hip.x - start.x, hy = hip.y - start.y, hz = hip.z - start.z;
    double dh = sqrt(hx * hx + hy * hy + hz * hz);
    double sep = (hip_i >= 0 ? hip_ev.s : INFINITY) - r;
    /* the candidates first (the nearest bodies are among them), then the others unless their
     * common bound already says none is nearer: the minimum does not depend on the order */
    int listed = g->broad && g->list_valid;
    for (int pass = listed ? 0 : 1; pass < 2; pass++) {
        int nx;
        const int *ix = pass == 0 ? g->cand : g->all;
        nx = pass == 0 ? g->ncand : g->n;
        if (pass == 1 && listed && (T.lout_s - r) - dh > sep) break;
        for (int q = 0; q < nx; q++) {
            int i = ix[q];
            if (i == hip_i || (pass == 1 && listed && g->in_cand[i])) continue;
            if (g->broad && g->B[i].bounded && (bound_at(&g->B[i], start) - r) - dh >= sep) continue;
            double f = ev_start(&T, i).s - r;
            if (f - dh < sep) sep = dmin(sep, body_eval(&g->B[i], hip).s - r);
        }
    }
    o->separation = sep;
    o->iterations = iterations;
    o->touch = tbuf;
    if (free_) {
        g->proxy = x;
        Py_CLEAR(g->friction_body);
        g->sticking = 0;
        o->proxy = x; o->force.x = o->force.y = o->force.z = 0.0; o->ntouch = 0;
        return;
    }
    double gx = x.x - start.x, gy = x.y - start.y, gz = x.z - start.z;
    double dx = sqrt(gx * gx + gy * gy + gz * gz);
    int *near = g->idx2, nnear = 0;
    {
        int nx;
        const int *ix = scan(&T, (T.lout_s - r) - dx, CONTACT_TOL + CULL_MARGIN, &nx);
        for (int q = 0; q < nx; q++) {
            int i = ix[q];
            if (g->broad && g->B[i].bounded && (bound_at(&g->B[i], start) - r) - dx > CONTACT_TOL + CULL_MARGIN) continue;
            if ((ev_start(&T, i).s - r) - dx <= CONTACT_TOL + CULL_MARGIN) near[nnear++] = i;
        }
    }
    int nt = touching(&T, near, nnear, hit_i, &hit_ev, x, hip, tbuf, 0);
    if (!nt) { tbuf[0].i = hit_i; tbuf[0].ev = body_eval(&g->B[hit_i], x); tbuf[0].depth = 0.0; nt = 1; }
    if (nt == 1) {
        const CBody *body = &g->B[tbuf[0].i];
        int rough = body->mus > 0.0 || body->mud > 0.0;
        int same = 0;
        if (rough && g->friction_body) {
            same = PyObject_RichCompareBool(g->friction_body, body->id, Py_EQ);
            if (same < 0) { PyErr_Clear(); same = 0; }
        }
        if (rough && same) {
            V3 x2;
            if (friction(&T, g, tbuf[0].i, tbuf[0].ev, x, xs, hip, &x2)) {
                x = x2;
                int nx;
                const int *ix = scan(&T, lout_at(g, x) - r, CONTACT_TOL, &nx);
                Touch *alt = tbuf + g->n + 1;
                int na = touching(&T, ix, nx, -1, NULL, x, hip, alt, 1);
                if (na) { memcpy(tbuf, alt, sizeof(Touch) * (size_t)na); nt = na; }
            }
        } else {
            g->sticking = rough;
        }
        Py_INCREF(body->id);
        Py_XSETREF(g->friction_body, body->id);
    } else {
        Py_CLEAR(g->friction_body);
        g->sticking = 0;
    }
    double k;
    if (nt == 1) k = g->B[tbuf[0].i].k;
    else {
        k = 0.0;
        for (int q = 0; q < nt; q++) k = q == 0 ? g->B[tbuf[q].i].k : k + g->B[tbuf[q].i].k;
        k = k / (double)nt;
    }
    g->proxy = x;
    o->proxy = x;
    o->force.x = k * (x.x - hip.x); o->force.y = k * (x.y - hip.y); o->force.z = k * (x.z - hip.z);
    o->ntouch = nt;
}

/* ------------------------------------------------------------------- Python glue ----------- */

static int get_double(PyObject *o, const char *name, double *out)
{
    PyObject *v = PyObject_GetAttrString(o, name);
    if (!v) return -1;
    *out = PyFloat_AsDouble(v);
    Py_DECREF(v);
    return (*out == -1.0 && PyErr_Occurred()) ? -1 : 0;
}

static int get_doubles(PyObject *o, const char *name, double *out, int n)
{
    PyObject *v = PyObject_GetAttrString(o, name);
    if (!v) return -1;
    PyObject *seq = PySequence_Fast(v, "expected a sequence");
    Py_DECREF(v);
    if (!seq) return -1;
    if (PySequence_Fast_GET_SIZE(seq) != n) { Py_DECREF(seq); PyErr_Format(PyExc_ValueError, "%s: expected %d numbers", name, n); return -1; }
    for (int i = 0; i < n; i++) {
        out[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(seq, i));
        if (out[i] == -1.0 && PyErr_Occurred()) { Py_DECREF(seq); return -1; }
    }
    Py_DECREF(seq);
    return 0;
}

/* a Body of one of the six primitives -> CBody: 1; anything else (a bench baseline's mesh or grid
 * body, a subclass): 0; error: -1 */
static int convert_body(PyObject *obj, CBody *cb)
{
    if (!BodyType || (PyObject *)Py_TYPE(obj) != BodyType) return 0;
    PyObject *shape = PyObject_GetAttrString(obj, "shape");
    if (!shape) return -1;
    int type = -1;
    for (int t = 0; t < NSHAPES; t++)
        if ((PyObject *)Py_TYPE(shape) == ShapeTypes[t]) type = t;
    int rc = 0;
    memset(cb, 0, sizeof *cb);
    cb->type = type;
    double lc[3] = {0.0, 0.0, 0.0}, lr = 0.0;  /* bounding ball, local frame */
    double *p = cb->p;
    switch (type) {
    case -1: Py_DECREF(shape); return 0;
    case SPHERE: case HEMISPHERE:
        rc = get_double(shape, "radius", &p[0]); lr = p[0]; break;
    case BOX:
        rc = get_doubles(shape, "_h", p, 3); lr = norm3(p[0], p[1], p[2]); break;
    case PLANE:
        rc = get_doubles(shape, "_h", p, 2); break;
    case CYLINDER:
        rc = get_double(shape, "radius", &p[0]);
        if (!rc) rc = get_double(shape, "_hh", &p[1]);
        lc[2] = p[1]; lr = sqrt(p[0] * p[0] + p[1] * p[1]); break;
    case CONE:
        rc = get_double(shape, "radius", &p[0]);
        if (!rc) rc = get_double(shape, "height", &p[1]);
        if (!rc) rc = get_doubles(shape, "_k", p + 2, 4);
        lc[2] = 0.5 * p[1]; lr = sqrt(p[0] * p[0] + lc[2] * lc[2]); break;
    }
    Py_DECREF(shape);
    if (rc) return -1;
    double o[3];
    if (get_doubles(obj, "_o", o, 3)) return -1;
    cb->ox = o[0]; cb->oy = o[1]; cb->oz = o[2];
    PyObject *m = PyObject_GetAttrString(obj, "_m");
    if (!m) return -1;
    cb->rot = m != Py_None;
    Py_DECREF(m);
    if (cb->rot && get_doubles(obj, "_m", cb->m, 9)) return -1;
    if (get_double(obj, "stiffness_n_per_m", &cb->k) || get_double(obj, "static_friction", &cb->mus)
            || get_double(obj, "dynamic_friction", &cb->mud)) return -1;
    cb->bounded = type != PLANE;
    if (cb->bounded) {
        const double *R = cb->m;
        double cx = lc[0], cy = lc[1], cz = lc[2];
        if (cb->rot) {
            cx = R[0] * lc[0] + R[1] * lc[1] + R[2] * lc[2];
            cy = R[3] * lc[0] + R[4] * lc[1] + R[5] * lc[2];
            cz = R[6] * lc[0] + R[7] * lc[1] + R[8] * lc[2];
        }
        cb->cx = cx + cb->ox; cb->cy = cy + cb->oy; cb->cz = cz + cb->oz;
        /* inflated so that rounding in the bound and in the exact distance cannot reorder them */
        cb->rho = lr * (1.0 + 1e-9) + 1e-9 * (1.0 + norm3(cb->cx, cb->cy, cb->cz));
    }
    cb->obj = obj;
    cb->id = PyObject_GetAttrString(obj, "id");  /* borrowed below: the body holds it */
    if (!cb->id) return -1;
    Py_DECREF(cb->id);
    return 1;
}

static void core_clear_scene(GodCore *g)
{
    Py_CLEAR(g->scene_tuple);
    for (int i = 0; i < g->n; i++) Py_XDECREF(g->objs[i]);
    g->n = 0;
    g->list_valid = 0;
}

static int core_reserve(GodCore *g, int n)
{
    if (n <= g->cap && g->cap > 0) return 0;
    int cap = n < 8 ? 8 : n;
    void *p;
#define GROW(field, type, count) \
    if (!(p = PyMem_Realloc(g->field, sizeof(type) * (size_t)(count)))) { PyErr_NoMemory(); return -1; } \
    g->field = p;
    GROW(objs, PyObject *, cap)
    GROW(B, CBody, cap)
    GROW(all, int, cap)
    GROW(cand, int, cap)
    GROW(ev0, Ev, cap)
    GROW(evs, Ev, cap)
    GROW(seen, unsigned, cap)
    GROW(in_cand, unsigned char, cap)
    GROW(idx, int, cap)
    GROW(idx2, int, cap)
    GROW(tbuf, Touch, 2 * cap + 2)
#undef GROW
    g->cap = cap;
    return 0;
}

/* the compiled scene for this body list: 1, 0 if some body is not a primitive, -1 on error.
 * Bodies are frozen, so the same objects in the same order are the same scene. */
static int core_sync(GodCore *g, PyObject *bodies)
{
    if (bodies == g->scene_tuple) return 1;  /* a tuple cannot have changed: no per-body check */
    PyObject *seq = PySequence_Fast(bodies, "bodies must be a sequence");
    if (!seq) return -1;
    Py_ssize_t n = PySequence_Fast_GET_SIZE(seq);
    PyObject **items = PySequence_Fast_ITEMS(seq);
    int same = n == g->n;
    for (Py_ssize_t i = 0; same && i < n; i++) same = items[i] == g->objs[i];
    if (same) { Py_DECREF(seq); return 1; }
    core_clear_scene(g);
    if (n > 1000000 || core_reserve(g, (int)n)) { Py_DECREF(seq); if (!PyErr_Occurred()) PyErr_NoMemory(); return -1; }
    for (Py_ssize_t i = 0; i < n; i++) {
        int rc = convert_body(items[i], &g->B[i]);
        if (rc <= 0) {
            for (Py_ssize_t j = 0; j < i; j++) Py_DECREF(g->objs[j]);
            g->n = 0;
            Py_DECREF(seq);
            return rc;
        }
        Py_INCREF(items[i]);
        g->objs[i] = items[i];
        g->all[i] = (int)i;
        g->seen[i] = 0;
    }
    g->n = (int)n;
    g->list_valid = 0;
    g->gen = 1;
    if (PyTuple_CheckExact(bodies)) { Py_INCREF(bodies); Py_XSETREF(g->scene_tuple, bodies); }
    Py_DECREF(seq);
    return 1;
}

static int to_v3(PyObject *o, V3 *v)
{
    PyObject *seq = PySequence_Fast(o, "expected a 3-vector");
    if (!seq) return -1;
    if (PySequence_Fast_GET_SIZE(seq) != 3) { Py_DECREF(seq); PyErr_SetString(PyExc_ValueError, "expected a 3-vector"); return -1; }
    double c[3];
    for (int i = 0; i < 3; i++) {
        c[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(seq, i));
        if (c[i] == -1.0 && PyErr_Occurred()) { Py_DECREF(seq); return -1; }
    }
    Py_DECREF(seq);
    v->x = c[0]; v->y = c[1]; v->z = c[2];
    return 0;
}

static PyObject *v3_tuple(V3 v)
{
    PyObject *t = PyTuple_New(3), *a = PyFloat_FromDouble(v.x), *b = PyFloat_FromDouble(v.y),
             *c = PyFloat_FromDouble(v.z);
    if (!t || !a || !b || !c) { Py_XDECREF(t); Py_XDECREF(a); Py_XDECREF(b); Py_XDECREF(c); return NULL; }
    PyTuple_SET_ITEM(t, 0, a);
    PyTuple_SET_ITEM(t, 1, b);
    PyTuple_SET_ITEM(t, 2, c);
    return t;
}

/* a frozen dataclass instance without running its __init__ (whose object.__setattr__ per field
 * costs more than the whole contact query) */
static PyObject *make_record(PyObject *cls, PyObject **names, PyObject **values, int n)
{
    PyTypeObject *tp = (PyTypeObject *)cls;
    PyObject *o = tp->tp_new(tp, empty_tuple, NULL);
    if (!o) return NULL;
    for (int i = 0; i < n; i++)
        if (!values[i] || PyObject_GenericSetAttr(o, names[i], values[i]) < 0) { Py_DECREF(o); return NULL; }
    return o;
}

static PyObject *core_step(GodCore *g, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 2) { PyErr_SetString(PyExc_TypeError, "step(bodies, hip)"); return NULL; }
    if (!ProxyStepType) { PyErr_SetString(PyExc_RuntimeError, "_chaptics.configure() was not called"); return NULL; }
    V3 hip;
    if (to_v3(args[1], &hip)) return NULL;
    int rc = core_sync(g, args[0]);
    if (rc < 0) return NULL;
    if (rc == 0) Py_RETURN_NONE;
    Touch *tbuf = g->tbuf;
    StepOut o;
    god_step(g, hip, &o, tbuf);
    PyObject *contacts = PyTuple_New(o.ntouch);
    double r = g->radius;
    for (int q = 0; contacts && q < o.ntouch; q++) {
        Touch *t = &o.touch[q];
        V3 nn = {t->ev.x, t->ev.y, t->ev.z};
        V3 pt = {o.proxy.x - r * t->ev.x, o.proxy.y - r * t->ev.y, o.proxy.z - r * t->ev.z};
        PyObject *names[4] = {s_body_id, s_normal, s_depth, s_point};
        PyObject *vals[4] = {g->B[t->i].id, v3_tuple(nn), PyFloat_FromDouble(t->depth), v3_tuple(pt)};
        Py_INCREF(vals[0]);
        PyObject *c = make_record(ContactType, names, vals, 4);
        for (int k = 0; k < 4; k++) Py_XDECREF(vals[k]);
        if (!c) { Py_CLEAR(contacts); break; }
        PyTuple_SET_ITEM(contacts, q, c);
    }
    if (!contacts) return NULL;
    PyObject *force;
    if (o.ntouch == 0) { force = zero_vec; Py_INCREF(force); } else force = v3_tuple(o.force);
    PyObject *names[5] = {s_proxy, s_force, s_contacts, s_separation, s_iterations};
    PyObject *vals[5] = {v3_tuple(o.proxy), force, contacts, PyFloat_FromDouble(o.separation),
                         PyLong_FromLong(o.iterations)};
    PyObject *res = make_record(ProxyStepType, names, vals, 5);
    for (int k = 0; k < 5; k++) Py_XDECREF(vals[k]);
    return res;
}

static int core_init(GodCore *g, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"radius", "max_iterations", "tolerance", "shortcut", NULL};
    double radius = 0.0, tol = 1e-12;
    int iters = 16, sc = 1;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "|didp", kwlist, &radius, &iters, &tol, &sc)) return -1;
    g->radius = radius; g->max_iterations = iters; g->tolerance = tol; g->use_shortcut = (char)sc;
    g->broad = 1;
    g->has_proxy = 0; g->sticking = 0;
    Py_CLEAR(g->friction_body);
    return 0;
}

static void core_dealloc(GodCore *g)
{
    core_clear_scene(g);
    Py_CLEAR(g->friction_body);
    PyMem_Free(g->objs); PyMem_Free(g->B); PyMem_Free(g->all); PyMem_Free(g->cand); PyMem_Free(g->ev0);
    PyMem_Free(g->evs); PyMem_Free(g->seen); PyMem_Free(g->in_cand); PyMem_Free(g->idx); PyMem_Free(g->idx2); PyMem_Free(g->tbuf);
    Py_TYPE(g)->tp_free((PyObject *)g);
}

static PyObject *core_get_proxy(GodCore *g, void *c)
{
    (void)c;
    if (!g->has_proxy) Py_RETURN_NONE;
    return v3_tuple(g->proxy);
}

static int core_set_proxy(GodCore *g, PyObject *v, void *c)
{
    (void)c;
    if (!v || v == Py_None) { g->has_proxy = 0; return 0; }
    if (to_v3(v, &g->proxy)) return -1;
    g->has_proxy = 1;
    return 0;
}

static PyObject *core_get_fb(GodCore *g, void *c)
{
    (void)c;
    PyObject *v = g->friction_body ? g->friction_body : Py_None;
    Py_INCREF(v);
    return v;
}

static int core_set_fb(GodCore *g, PyObject *v, void *c)
{
    (void)c;
    if (v == Py_None) v = NULL;
    Py_XINCREF(v);
    Py_XSETREF(g->friction_body, v);
    return 0;
}

static PyObject *core_get_sticking(GodCore *g, void *c) { (void)c; return PyBool_FromLong(g->sticking); }

static int core_set_sticking(GodCore *g, PyObject *v, void *c)
{
    (void)c;
    int b = v ? PyObject_IsTrue(v) : 0;
    if (b < 0) return -1;
    g->sticking = b;
    return 0;
}

static PyGetSetDef core_getset[] = {
    {"proxy", (getter)core_get_proxy, (setter)core_set_proxy, "the proxy, or None", NULL},
    {"friction_body", (getter)core_get_fb, (setter)core_set_fb, "id of the body touched last tick", NULL},
    {"sticking", (getter)core_get_sticking, (setter)core_set_sticking, "held by static friction", NULL},
    {NULL}
};

static PyMemberDef core_members[] = {
    {"radius", T_DOUBLE, offsetof(GodCore, radius), 0, NULL},
    {"max_iterations", T_INT, offsetof(GodCore, max_iterations), 0, NULL},
    {"tolerance", T_DOUBLE, offsetof(GodCore, tolerance), 0, NULL},
    {"use_shortcut", T_BOOL, offsetof(GodCore, use_shortcut), 0, NULL},
    {"broad_phase", T_BOOL, offsetof(GodCore, broad), 0, "skip far bodies by their bounding balls (the bench turns it off to show what it saves)"},
    {NULL}
};

static PyMethodDef core_methods[] = {
    {"step", (PyCFunction)(void (*)(void))core_step, METH_FASTCALL,
     "step(bodies, hip) -> ProxyStep, or None if a body is not one of the primitives"},
    {NULL}
};

static PyTypeObject GodCoreType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "server.core.haptics._chaptics.GodCore",
    .tp_basicsize = sizeof(GodCore),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "The god-object's state and its compiled step (god_object.GodObject wraps it).",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)core_init,
    .tp_dealloc = (destructor)core_dealloc,
    .tp_methods = core_methods,
    .tp_members = core_members,
    .tp_getset = core_getset,
};

/* ---------------------------------------------------------------- the contact gate --------- */

typedef struct {
    PyObject_HEAD
    double band, min_on_s, min_off_s, t_change;
    char on, has_change;
} Gate;

static PyObject *gate_update(Gate *s, PyObject *const *args, Py_ssize_t nargs)  /* ContactGate.update */
{
    if (nargs != 3) { PyErr_SetString(PyExc_TypeError, "update(t_s, touching, separation)"); return NULL; }
    double t = PyFloat_AsDouble(args[0]);
    if (t == -1.0 && PyErr_Occurred()) return NULL;
    int touching = PyObject_IsTrue(args[1]);
    if (touching < 0) return NULL;
    double sep = PyFloat_AsDouble(args[2]);
    if (sep == -1.0 && PyErr_Occurred()) return NULL;
    double since = s->has_change ? t - s->t_change : INFINITY;
    if (s->on) {
        if (sep >= s->band && since >= s->min_on_s) { s->on = 0; s->t_change = t; s->has_change = 1; }
    } else if (touching && since >= s->min_off_s) {
        s->on = 1; s->t_change = t; s->has_change = 1;
    }
    return PyBool_FromLong(s->on);
}

static PyObject *gate_reset(Gate *s, PyObject *unused)
{
    (void)unused;
    s->on = 0; s->has_change = 0;
    Py_RETURN_NONE;
}

static PyObject *gate_get_on(Gate *s, void *c) { (void)c; return PyBool_FromLong(s->on); }

static int gate_set_on(Gate *s, PyObject *v, void *c)
{
    (void)c;
    int b = v ? PyObject_IsTrue(v) : 0;
    if (b < 0) return -1;
    s->on = (char)b;
    return 0;
}

static PyObject *gate_get_tc(Gate *s, void *c)
{
    (void)c;
    if (!s->has_change) Py_RETURN_NONE;
    return PyFloat_FromDouble(s->t_change);
}

static int gate_set_tc(Gate *s, PyObject *v, void *c)
{
    (void)c;
    if (!v || v == Py_None) { s->has_change = 0; return 0; }
    double t = PyFloat_AsDouble(v);
    if (t == -1.0 && PyErr_Occurred()) return -1;
    s->t_change = t; s->has_change = 1;
    return 0;
}

static PyGetSetDef gate_getset[] = {
    {"on", (getter)gate_get_on, NULL, "the gated contact state", NULL},
    {"_on", (getter)gate_get_on, (setter)gate_set_on, NULL, NULL},
    {"_t_change", (getter)gate_get_tc, (setter)gate_set_tc, "time of the last transition, or None", NULL},
    {NULL}
};

static PyMemberDef gate_members[] = {
    {"band", T_DOUBLE, offsetof(Gate, band), 0, NULL},
    {"min_on_s", T_DOUBLE, offsetof(Gate, min_on_s), 0, NULL},
    {"min_off_s", T_DOUBLE, offsetof(Gate, min_off_s), 0, NULL},
    {NULL}
};

static PyMethodDef gate_methods[] = {
    {"update", (PyCFunction)(void (*)(void))gate_update, METH_FASTCALL, "update(t_s, touching, separation) -> bool"},
    {"reset", (PyCFunction)gate_reset, METH_NOARGS, "off, with no dwell pending"},
    {NULL}
};

static PyTypeObject GateType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "server.core.haptics._chaptics.Gate",
    .tp_basicsize = sizeof(Gate),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE,
    .tp_doc = "The contact gate's state and update (contact_gate.ContactGate subclasses it).",
    .tp_new = PyType_GenericNew,
    .tp_methods = gate_methods,
    .tp_members = gate_members,
    .tp_getset = gate_getset,
};

/* ------------------------------------------------------------------- module -------------- */

static PyObject *mod_configure(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *body, *shapes, *ps, *ct;
    if (!PyArg_ParseTuple(args, "OOOO", &body, &shapes, &ps, &ct)) return NULL;
    static const char *names[NSHAPES] = {"sphere", "box", "cylinder", "cone", "plane", "hemisphere"};
    for (int t = 0; t < NSHAPES; t++) {
        PyObject *c = PyMapping_GetItemString(shapes, names[t]);
        if (!c) return NULL;
        Py_XSETREF(ShapeTypes[t], c);
    }
    Py_INCREF(body); Py_XSETREF(BodyType, body);
    Py_INCREF(ps); Py_XSETREF(ProxyStepType, ps);
    Py_INCREF(ct); Py_XSETREF(ContactType, ct);
    Py_RETURN_NONE;
}

static int one_body(PyObject *body, CBody *cb)
{
    int rc = convert_body(body, cb);
    if (rc == 0) PyErr_SetString(PyExc_TypeError, "not a Body of one of the primitives");
    return rc == 1 ? 0 : -1;
}

static PyObject *mod_evaluate(PyObject *self, PyObject *args)  /* Body._eval */
{
    (void)self;
    PyObject *body, *po;
    CBody cb;
    V3 p;
    if (!PyArg_ParseTuple(args, "OO", &body, &po) || one_body(body, &cb) || to_v3(po, &p)) return NULL;
    Ev e = body_eval(&cb, p);
    return Py_BuildValue("(dddd)", e.s, e.x, e.y, e.z);
}

static PyObject *mod_cast(PyObject *self, PyObject *args)  /* Body.cast */
{
    (void)self;
    PyObject *body, *ao, *bo;
    double radius = 0.0;
    CBody cb;
    V3 a, b;
    if (!PyArg_ParseTuple(args, "OOO|d", &body, &ao, &bo, &radius) || one_body(body, &cb) || to_v3(ao, &a)
            || to_v3(bo, &b)) return NULL;
    Hit h;
    if (!body_cast(&cb, a, b.x - a.x, b.y - a.y, b.z - a.z, radius, 1.0, NULL, NULL, -1, &h)) Py_RETURN_NONE;
    return PyFloat_FromDouble(h.t);
}

static PyMethodDef mod_methods[] = {
    {"configure", mod_configure, METH_VARARGS, "configure(Body, SHAPE_TYPES, ProxyStep, Contact)"},
    {"evaluate", mod_evaluate, METH_VARARGS, "evaluate(body, p) -> (sd, nx, ny, nz), like Body._eval"},
    {"cast", mod_cast, METH_VARARGS, "cast(body, a, b, radius=0) -> t or None, like Body.cast"},
    {NULL}
};

static struct PyModuleDef moddef = {PyModuleDef_HEAD_INIT, "_chaptics",
    "The compiled haptic core (see _chaptics.c; the Python modules beside it are the reference).", -1, mod_methods};

PyMODINIT_FUNC PyInit__chaptics(void)
{
    if (PyType_Ready(&GodCoreType) < 0 || PyType_Ready(&GateType) < 0) return NULL;
    PyObject *m = PyModule_Create(&moddef);
    if (!m) return NULL;
#define INTERN(var, text) if (!(var = PyUnicode_InternFromString(text))) return NULL;
    INTERN(s_proxy, "proxy") INTERN(s_force, "force") INTERN(s_contacts, "contacts")
    INTERN(s_separation, "separation") INTERN(s_iterations, "iterations") INTERN(s_body_id, "body_id")
    INTERN(s_normal, "normal") INTERN(s_depth, "depth") INTERN(s_point, "point")
#undef INTERN
    if (!(empty_tuple = PyTuple_New(0)) || !(zero_vec = Py_BuildValue("(ddd)", 0.0, 0.0, 0.0))) return NULL;
    Py_INCREF(&GodCoreType);
    Py_INCREF(&GateType);
    if (PyModule_AddObject(m, "GodCore", (PyObject *)&GodCoreType) < 0
            || PyModule_AddObject(m, "Gate", (PyObject *)&GateType) < 0
            || PyModule_AddIntConstant(m, "VERSION", CORE_VERSION) < 0) return NULL;
    return m;
}
