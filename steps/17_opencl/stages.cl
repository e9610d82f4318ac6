// Chapter 17's stages: chapter 16's wavefront, one kernel per stage, one work-item per path (or shadow ray).
//   generate → extend → shade → connect → accumulate, and back to extend with the paths that go on.
// The paths live in structure-of-arrays queues in the device's memory (path i is entry i of every array), so that
// neighbouring work-items read neighbouring words: what a GPU's memory serves in one transaction.

// The scene's arguments, as every kernel that traces or shades takes them, and the Geometry they make.
#define GEOMETRY_ARGS                                                                                                 \
  __global const float4 *spheres, __global const int *sphereMaterials, __global const float4 *vertices,              \
      __global const uint4 *triangles, __global const WideNode *nodes, __global const uint *leafSpheres,             \
      __global const uint *leafTriangles, __global const int *outside, const int sphereCount,                        \
      const int triangleCount, const int nodeCount, const int outsideCount
#define MAKE_GEOMETRY(g)                                                                                              \
  Geometry g;                                                                                                         \
  g.spheres = spheres;                                                                                                \
  g.sphereMaterials = sphereMaterials;                                                                                \
  g.vertices = vertices;                                                                                              \
  g.triangles = triangles;                                                                                            \
  g.nodes = nodes;                                                                                                    \
  g.leafSpheres = leafSpheres;                                                                                        \
  g.leafTriangles = leafTriangles;                                                                                    \
  g.outside = outside;                                                                                                \
  g.sphereCount = sphereCount;                                                                                        \
  g.triangleCount = triangleCount;                                                                                    \
  g.nodeCount = nodeCount;                                                                                            \
  g.outsideCount = outsideCount

/// [generate]
// Stage 1, generate: pixel sample i's random numbers, keyed by (seed, pixel, sample), and its camera ray, made as
// the render loop makes every chapter's (PrimaryRays: where in the pixel, then the pinhole's direction).
__kernel void generate(__global const int4* keys, const uint n, const ulong seed, const int jittered,
                       const int strata, const float4 eye, const float4 u, const float4 v, const float4 w,
                       const float4 image, // half width, half height, width, height
                       __global float4* origin, __global float4* direction, __global float4* beta,
                       __global float4* from, __global ulong2* rng, __global uint* slot, __global float4* radiance)
{
  const uint i = get_global_id(0);
  if (i >= n)
    return;
  const int4 key = keys[i];
  Rng r = samplerMake(seed, key.x, key.y, (ulong)key.z);
  float2 offset = (float2)(0.5f, 0.5f);
  if (jittered && strata == 0) {
    offset = pixelSequencePoint(seed, key.x, key.y, (uint)key.z);
  } else if (jittered) {
    const float jx = next1D(&r);
    const float jy = next1D(&r);
    offset = (float2)(jx, jy);
    if (strata > 1 && (long)key.z < (long)strata * strata)
      offset = (float2)(((float)(key.z % strata) + jx) / (float)strata, ((float)(key.z / strata) + jy) / (float)strata);
  }
  const float fx = (float)key.x + offset.x, fy = (float)key.y + offset.y;
  const float x = (2.0f * fx / image.z - 1.0f) * image.x;
  const float y = (1.0f - 2.0f * fy / image.w) * image.y;
  origin[i] = (float4)(eye.xyz, 0.0f);
  direction[i] = (float4)(normalize(u.xyz * x + v.xyz * y - w.xyz), 0.0f);
  beta[i] = (float4)(1.0f, 1.0f, 1.0f, 0.0f); // throughput; w: the pdf of the last BSDF sample
  from[i] = (float4)(0.0f, 0.0f, 0.0f, 1.0f); // the last vertex; w: 1 when its bounce was specular (or the camera)
  rng[i] = (ulong2)(r.state, r.inc);
  slot[i] = i;
  radiance[i] = (float4)(0.0f);
}
/// [generate]

/// [extend]
// Stage 2, extend: the nearest hit of every path's ray: (t, primitive), primitive −1 for a miss.
__kernel void extend(GEOMETRY_ARGS, const uint n, __global const float4* origin, __global const float4* direction,
                     __global float* hitT, __global int* hitPrimitive)
{
  const uint i = get_global_id(0);
  if (i >= n)
    return;
  MAKE_GEOMETRY(g);
  const float2 hit = traceRay(&g, origin[i].xyz, direction[i].xyz, INFINITY, 0);
  hitT[i] = hit.x;
  hitPrimitive[i] = as_int(hit.y);
}
/// [extend]

/// [shade]
// What shade makes of one path: whether it goes on, with its next ray and state, and whether it sends a shadow ray.
typedef struct {
  int goesOn, hasShadow;
  float4 origin, direction, beta, from; // the next round's entry, as the path queue holds it
  ulong2 rng;
  float4 shadowOrigin, shadowDirection, shadowLight;
} Shaded;

// Stage 3, shade: at every path's hit, what chapter 8's loop does at a vertex. Emission found by the BSDF's ray
// (weighted against light sampling); a light sample, whose shadow ray goes to connect's queue with the light it
// would bring; the BSDF sample that continues the path; Russian roulette. This is one path's part (path i); the
// kernel below appends what it makes to the queues.
Shaded shadePath(GEOMETRY_ARGS, __global const float4* materials, __global const int4* lightInfo,
                 __global const float* lightCdf, __global const float* lightProbability,
                 __global const float4* pointLights, const int lightCount, __global const float4* vertexNormals,
                 __global const uchar* smooth, const int hasNormals, const float4 background,
                 __global const float4* environment, const float4 environmentInfo, const int bounce, const int maxDepth,
                 const int power, const uint i, __global const float4* origin, __global const float4* direction,
                 __global const float4* beta, __global const float4* from, __global const ulong2* rng,
                 __global const uint* slot, __global const float* hitT, __global const int* hitPrimitive,
                 __global float4* radiance)
{
  Shaded out;
  out.goesOn = 0;
  out.hasShadow = 0;
  MAKE_GEOMETRY(g);
  Lights lights;
  lights.info = lightInfo;
  lights.cdf = lightCdf;
  lights.probability = lightProbability;
  lights.pointLights = pointLights;
  lights.count = lightCount;

  const float3 o = origin[i].xyz, d = direction[i].xyz;
  float3 b = beta[i].xyz;
  const float bsdfPdfPrev = beta[i].w;
  const int specularBounce = from[i].w != 0.0f;
  const uint s = slot[i];
  Rng r;
  r.state = rng[i].x;
  r.inc = rng[i].y;
  float3 L = (float3)(0.0f);

  // A ray that leaves the scene sees the background, or the environment map (only BSDF sampling finds it: weight 1).
  const int p = hitPrimitive[i];
  if (p < 0) {
    radiance[s] += (float4)(b * escapedRadiance(environment, environmentInfo, background.xyz, d), 0.0f);
    return out;
  }
  // The hit record (Scene::hitAt): a sphere's point re-projected, a triangle's from its barycentrics.
  SurfacePoint hit;
  float3 normal;
  if (p < sphereCount) {
    const float4 sphere = spheres[p];
    hit = sphereSurfacePoint(o, d, hitT[i], sphere.xyz, sphere.w);
    normal = hit.normal;
  } else {
    const uint4 tri = triangles[p - sphereCount];
    const float3 p0 = vertexAt(&g, tri.x), p1 = vertexAt(&g, tri.y), p2 = vertexAt(&g, tri.z);
    float4 bary = intersectTriangle(o, d, p0, p1, p2, 0.0f, INFINITY);
    if (bary.x < 0.0f)
      bary = (float4)(hitT[i], 1.0f / 3.0f, 1.0f / 3.0f, 1.0f / 3.0f);
    hit.point = bary.y * p0 + bary.z * p1 + bary.w * p2;
    hit.error = gammaF(7) * (fabs(bary.y * p0) + fabs(bary.z * p1) + fabs(bary.w * p2));
    hit.normal = triangleNormal(p0, p1, p2);
    normal = hit.normal;
    if (hasNormals && smooth[p - sphereCount]) {
      const float3 interpolated = bary.y * vertexNormals[tri.x].xyz + bary.z * vertexNormals[tri.y].xyz +
                                  bary.w * vertexNormals[tri.z].xyz;
      const float3 shading = safeNormalize(interpolated, hit.normal);
      normal = dot(shading, hit.normal) < 0.0f ? -shading : shading;
    }
  }
  const Material m = materialAt(materials, materialOf(&g, p));

  // Le(x, ωo), found by BSDF sampling: weighted against the chance that light sampling found it too.
  if (isEmissive(&m))
    L += b * m.emission *
         (specularBounce ? 1.0f : misWeight(power, bsdfPdfPrev, lightPdf(&g, &lights, from[i].xyz, p, hit.point)));
  if (bounce == maxDepth) {
    radiance[s] += (float4)(L, 0.0f);
    return out;
  }
  const Frame frame = frameFromNormal(normal);
  const float3 wo = toLocal(&frame, -d);

  // Light sampling, weighted against the chance that the BSDF chose the same direction, and its shadow ray.
  if (m.type != kMirror && m.type != kGlass) {
    const float uLight = next1D(&r);
    const float u1 = next1D(&r);
    const float2 uDirection = (float2)(u1, next1D(&r));
    if (lightCount > 0) {
      const LightSample ls =
          sampleLight(&g, &lights, materials, hit.point, hit.error, hit.normal, uLight, uDirection);
      if (ls.pdf > 0.0f) {
        const float3 wi = toLocal(&frame, ls.wi);
        const float3 f = bsdfEval(&m, wo, wi);
        if (f.x != 0.0f || f.y != 0.0f || f.z != 0.0f) {
          const float weight = ls.delta ? 1.0f : misWeight(power, ls.pdf, bsdfPdf(&m, wo, wi));
          out.hasShadow = 1;
          out.shadowOrigin = (float4)(ls.origin, ls.tmax);
          out.shadowDirection = (float4)(ls.wi, 0.0f);
          out.shadowLight = (float4)(b * f * fabs(wi.z) * ls.Li * (weight / ls.pdf), 0.0f);
        }
      }
    }
  }
  radiance[s] += (float4)(L, 0.0f);

  // BSDF sampling: the path goes on, and remembers the pdf for the emitter it may hit next.
  const float uChoice = next1D(&r);
  const float u1 = next1D(&r);
  const float2 u = (float2)(u1, next1D(&r));
  const BsdfSample bs = bsdfSample(&m, wo, u, uChoice);
  if (!(bs.pdf > 0.0f))
    return out;
  b *= bs.f * fabs(bs.wi.z) / bs.pdf;
  if (b.x == 0.0f && b.y == 0.0f && b.z == 0.0f)
    return out; // nothing more can reach the eye along this path
  // Russian roulette: go on with probability q, and divide by q so that the expectation is unchanged.
  if (bounce >= kRouletteMinBounces) {
    const float q = fmin(kRouletteMaxSurvival, fmax(b.x, fmax(b.y, b.z)));
    if (next1D(&r) >= q)
      return out;
    b /= q;
  }
  const float3 wi = toWorld(&frame, bs.wi);
  out.goesOn = 1;
  out.origin = (float4)(offsetRayOrigin(hit.point, hit.error, hit.normal, wi), 0.0f);
  out.direction = (float4)(wi, 0.0f);
  out.beta = (float4)(b, bs.pdf);
  out.from = (float4)(hit.point, bs.specular ? 1.0f : 0.0f);
  out.rng = (ulong2)(r.state, r.inc);
  return out;
}
/// [shade]

/// [append]
// The kernel: every path's part, then the appends. A work-group finds where each of its paths that go on and each
// of its shadow rays goes among the group's (a scan of the two flags, packed into one number), then takes its places
// in the two queues with one atomic add a queue. Within a group the queues keep the paths' order; the groups come
// in any order, which changes nothing, as each path's numbers are its own. (One global atomic a work-item would
// have the work-items of both cores take the counters' cache line in turn: see the measurements page.)
__kernel __attribute__((reqd_work_group_size(GROUP_SIZE, 1, 1))) void
shade(GEOMETRY_ARGS, __global const float4* materials, __global const int4* lightInfo, __global const float* lightCdf,
      __global const float* lightProbability, __global const float4* pointLights, const int lightCount,
      __global const float4* vertexNormals, __global const uchar* smooth, const int hasNormals,
      const float4 background, __global const float4* environment, const float4 environmentInfo, const int bounce,
      const int maxDepth, const int power, const uint n,
      // this round's paths and their hits
      __global const float4* origin, __global const float4* direction, __global const float4* beta,
      __global const float4* from, __global const ulong2* rng, __global const uint* slot, __global const float* hitT,
      __global const int* hitPrimitive,
      // the next round's paths, the shadow rays, and where the counts go
      __global float4* nextOrigin, __global float4* nextDirection, __global float4* nextBeta, __global float4* nextFrom,
      __global ulong2* nextRng, __global uint* nextSlot, __global float4* shadowOrigin,
      __global float4* shadowDirection, __global float4* shadowLight, __global uint* shadowSlot,
      __global uint* counts, __global float4* radiance)
{
  __local uint partial[GROUP_SIZE], groupBase[2];
  const uint i = get_global_id(0);
  Shaded out;
  out.goesOn = out.hasShadow = 0;
  if (i < n) // (every work-item, past n too, must reach the barriers)
    out = shadePath(spheres, sphereMaterials, vertices, triangles, nodes, leafSpheres, leafTriangles, outside,
                    sphereCount, triangleCount, nodeCount, outsideCount, materials, lightInfo, lightCdf,
                    lightProbability, pointLights, lightCount, vertexNormals, smooth, hasNormals, background,
                    environment, environmentInfo, bounce, maxDepth, power, i, origin, direction, beta, from, rng,
                    slot, hitT, hitPrimitive, radiance);
  // (The two flags in one number, the paths' in the low 16 bits: a group's sums are at most GROUP_SIZE, below 2^16.)
  uint total;
  const uint before = groupExclusiveScan((uint)out.goesOn | (uint)out.hasShadow << 16, partial, &total);
  if (get_local_id(0) == 0) {
    groupBase[0] = atomic_add(&counts[0], total & 0xffffu);
    groupBase[1] = atomic_add(&counts[1], total >> 16);
  }
  barrier(CLK_LOCAL_MEM_FENCE);
  if (out.goesOn) {
    const uint k = groupBase[0] + (before & 0xffffu);
    nextOrigin[k] = out.origin;
    nextDirection[k] = out.direction;
    nextBeta[k] = out.beta;
    nextFrom[k] = out.from;
    nextRng[k] = out.rng;
    nextSlot[k] = slot[i];
  }
  if (out.hasShadow) {
    const uint k = groupBase[1] + (before >> 16);
    shadowOrigin[k] = out.shadowOrigin;
    shadowDirection[k] = out.shadowDirection;
    shadowLight[k] = out.shadowLight;
    shadowSlot[k] = slot[i];
  }
}
/// [append]

/// [connect]
// Stage 4, connect: every shadow ray of the round (any hit), blocked or not.
__kernel void connect(GEOMETRY_ARGS, __global const uint* counts, __global const float4* shadowOrigin,
                      __global const float4* shadowDirection, __global uchar* blocked)
{
  const uint i = get_global_id(0);
  if (i >= counts[1])
    return;
  MAKE_GEOMETRY(g);
  const float4 o = shadowOrigin[i];
  blocked[i] = as_int(traceRay(&g, o.xyz, shadowDirection[i].xyz, o.w, 1).y) >= 0;
}
/// [connect]

/// [accumulate]
// Stage 5, accumulate: the light of each shadow ray that got through, added to its pixel sample. (One shadow ray a
// path a round, and one path a pixel sample: no two work-items add to one sample, so no atomics are needed.)
__kernel void accumulate(__global const uint* counts, __global const float4* shadowLight,
                         __global const uint* shadowSlot, __global const uchar* blocked, __global float4* radiance)
{
  const uint i = get_global_id(0);
  if (i >= counts[1] || blocked[i])
    return;
  radiance[shadowSlot[i]] += shadowLight[i];
}
/// [accumulate]
