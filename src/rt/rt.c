/* Embree 3 back end. Pitfalls: ray.mask must be -1 (all bits) or every
 * geometry is skipped; 8-wide packets are native on AVX2 CPUs. */
#include "rt.h"

#include <embree3/rtcore.h>
#include <stdio.h>
#include <string.h>

struct pgi_rt {
    RTCDevice device;
    RTCScene scene;
};

static _Thread_local char g_rt_error[256];

static void on_error(void *user, enum RTCError code, const char *str) {
    (void)user;
    snprintf(g_rt_error, sizeof g_rt_error, "Embree error %d: %s", (int)code, str ? str : "");
}

pgi_status pgi__rt_create(const pgi_scene *s, pgi_rt **out) {
    *out = NULL;
    g_rt_error[0] = 0;
    pgi_rt *rt = calloc(1, sizeof *rt);
    if (!rt) return pgi__fail(PGI_ERR_OOM, "out of memory creating the ray tracer");
    rt->device = rtcNewDevice(NULL);
    if (!rt->device) {
        free(rt);
        return pgi__fail(PGI_ERR_INTERNAL, "cannot create an Embree device (error %d)", (int)rtcGetDeviceError(NULL));
    }
    rtcSetDeviceErrorFunction(rt->device, on_error, NULL);
    rt->scene = rtcNewScene(rt->device);
    rtcSetSceneBuildQuality(rt->scene, RTC_BUILD_QUALITY_HIGH);
    RTCGeometry g = rtcNewGeometry(rt->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), s->nverts);
    unsigned *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), s->ntris);
    if (!vb || !ib) {
        rtcReleaseGeometry(g);
        pgi__rt_destroy(rt);
        return pgi__fail(PGI_ERR_OOM, "Embree could not allocate geometry buffers for %zu triangles", s->ntris);
    }
    memcpy(vb, s->pos, s->nverts * 3 * sizeof(float));
    memcpy(ib, s->tri, s->ntris * 3 * sizeof(unsigned));
    rtcCommitGeometry(g);
    rtcAttachGeometry(rt->scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(rt->scene);
    if (rtcGetDeviceError(rt->device) != RTC_ERROR_NONE || g_rt_error[0]) {
        pgi_status st = pgi__fail(PGI_ERR_INTERNAL, "building the ray-tracing BVH failed: %s", g_rt_error);
        pgi__rt_destroy(rt);
        return st;
    }
    *out = rt;
    return PGI_OK;
}

void pgi__rt_destroy(pgi_rt *rt) {
    if (!rt) return;
    if (rt->scene) rtcReleaseScene(rt->scene);
    if (rt->device) rtcReleaseDevice(rt->device);
    free(rt);
}

int pgi__rt_intersect(const pgi_rt *rt, pgi_v3 o, pgi_v3 d, float tnear, float tfar, pgi_hit *h) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit rh;
    rh.ray.org_x = o.x; rh.ray.org_y = o.y; rh.ray.org_z = o.z;
    rh.ray.dir_x = d.x; rh.ray.dir_y = d.y; rh.ray.dir_z = d.z;
    rh.ray.tnear = tnear;
    rh.ray.tfar = tfar;
    rh.ray.time = 0.f;
    rh.ray.mask = (unsigned)-1;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(rt->scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
        h->prim = UINT32_MAX;
        return 0;
    }
    h->t = rh.ray.tfar;
    h->u = rh.hit.u;
    h->v = rh.hit.v;
    h->prim = rh.hit.primID;
    return 1;
}

int pgi__rt_occluded(const pgi_rt *rt, pgi_v3 o, pgi_v3 d, float tnear, float tfar) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay r;
    r.org_x = o.x; r.org_y = o.y; r.org_z = o.z;
    r.dir_x = d.x; r.dir_y = d.y; r.dir_z = d.z;
    r.tnear = tnear;
    r.tfar = tfar;
    r.time = 0.f;
    r.mask = (unsigned)-1;
    r.id = 0;
    r.flags = 0;
    rtcOccluded1(rt->scene, &ctx, &r);
    return r.tfar < 0.f;   /* Embree sets tfar to -inf when occluded */
}

void pgi__rt_intersect8(const pgi_rt *rt, const int valid[8], pgi_v3 o, const pgi_v3 dirs[8], float tfar,
                        pgi_hit hits[8]) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    RTC_ALIGN(32) struct RTCRayHit8 rh;
    RTC_ALIGN(32) int vmask[8];
    for (int i = 0; i < 8; i++) {
        vmask[i] = valid[i] ? -1 : 0;
        rh.ray.org_x[i] = o.x; rh.ray.org_y[i] = o.y; rh.ray.org_z[i] = o.z;
        rh.ray.dir_x[i] = dirs[i].x; rh.ray.dir_y[i] = dirs[i].y; rh.ray.dir_z[i] = dirs[i].z;
        rh.ray.tnear[i] = 0.f;
        rh.ray.tfar[i] = tfar;
        rh.ray.time[i] = 0.f;
        rh.ray.mask[i] = (unsigned)-1;
        rh.ray.id[i] = (unsigned)i;
        rh.ray.flags[i] = 0;
        rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect8(vmask, rt->scene, &ctx, &rh);
    for (int i = 0; i < 8; i++) {
        if (!valid[i] || rh.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID) {
            hits[i].prim = UINT32_MAX;
            continue;
        }
        hits[i].t = rh.ray.tfar[i];
        hits[i].u = rh.hit.u[i];
        hits[i].v = rh.hit.v[i];
        hits[i].prim = rh.hit.primID[i];
    }
}
