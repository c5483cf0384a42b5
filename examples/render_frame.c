/* Renders one frame through photongi's public API and writes it as a PNG.
 *
 *   render_frame [SCENE [OUT.png [WIDTHxHEIGHT]]]
 *
 * SCENE is anything pgi_scene_load takes: a built-in scene ("cornell", the default,
 * "giref", "sphere-and-plane", "cutout": no files needed), a scene description (.json) or a mesh
 * (OBJ, glTF, PLY). OUT.png defaults to render_frame.png, the size to 320x240.
 *
 * Build it against an installed photongi:
 *   cc render_frame.c $(pkg-config --cflags --libs photongi) -o render_frame
 * or with CMake (examples/CMakeLists.txt, find_package(photongi)). */
#include <stdio.h>
#include <string.h>

#include <photongi/photongi.h>

static int fail(const char *what, pgi_status s) {
    fprintf(stderr, "render_frame: %s: %s: %s\n", what, pgi_status_string(s), pgi_last_error());
    return 1;
}

int main(int argc, char **argv) {
    const char *spec = argc > 1 ? argv[1] : "cornell";
    const char *out = argc > 2 ? argv[2] : "render_frame.png";
    int width = 320, height = 240;
    if (argc > 3 && (sscanf(argv[3], "%dx%d", &width, &height) != 2 || width < 1 || height < 1)) {
        fprintf(stderr, "render_frame: size '%s' is not WIDTHxHEIGHT\n", argv[3]);
        return 2;
    }
    if (argc > 4) {
        fprintf(stderr, "usage: render_frame [SCENE [OUT.png [WIDTHxHEIGHT]]]\n");
        return 2;
    }

    /* The headers and the library must be the same version. */
    if (strcmp(pgi_version(), PGI_VERSION_STRING) != 0) {
        fprintf(stderr, "render_frame: headers are photongi %s, the library is %s\n", PGI_VERSION_STRING,
                pgi_version());
        return 1;
    }

    pgi_scene *scene;
    pgi_status s = pgi_scene_load(spec, &scene);
    if (s != PGI_OK) return fail("loading the scene", s);
    pgi_scene_info info;
    pgi_scene_get_info(scene, &info);

    pgi_renderer *r;
    s = pgi_renderer_create(scene, &r);
    if (s != PGI_OK) {
        pgi_scene_destroy(scene);
        return fail("creating the renderer", s);
    }

    /* Zero means default: the default estimator, radius, bounces, seed and threads. */
    pgi_render_desc desc = {.photons = 50000, .width = width, .height = height};
    pgi_image img = {0};
    pgi_frame_stats st;
    s = pgi_renderer_render(r, &desc, &img, &st);
    if (s == PGI_OK) s = pgi_image_write(&img, out, 1.0f);
    if (s == PGI_OK)
        printf("photongi %s: %s (%zu triangles), %s, %dx%d, %llu photons, %.1f ms -> %s\n", pgi_version(), info.name,
               info.triangles, st.estimator, st.width, st.height, (unsigned long long)st.photons_stored, st.total_ms,
               out);

    pgi_image_free(&img);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(scene);
    return s == PGI_OK ? 0 : fail("rendering", s);
}
