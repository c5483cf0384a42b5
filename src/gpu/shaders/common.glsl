// Shared by the compute shaders: the linear invocation index of a 1D kernel dispatched as a 2D grid
// of workgroups (pgi__gpu_dispatch's x count is limited to 65535 on some devices; gpu_hashgrid.c
// groups_2d() splits large counts into rows).
#ifndef PGIS_COMMON_GLSL
#define PGIS_COMMON_GLSL

uint linear_group() { return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x; }

#endif
