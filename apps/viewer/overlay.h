/* The viewer's overlay text (header only, no SDL, so that tests can draw
 * with it): lines in the built-in 5x7 font on a packed RGB8 image, each
 * glyph with a 1-pixel black shadow, all of them over a translucent black
 * box, so that white text stays readable over a white scene. */
#ifndef PGI__VIEW_OVERLAY_H
#define PGI__VIEW_OVERLAY_H

#include <string.h>

#include "font5x7.h"

/* What the box behind the text keeps of the image: a quarter (75 % black). On
 * any scene, white text then has a contrast ratio of at least 10:1 against
 * the box and the grey help line (190) 5.6:1 (WCAG asks 4.5:1 for small
 * text), and the scene still shows through. */
#define OVERLAY_BOX_KEEP 0.25f

/* Character cell: 6 x 10 pixels at scale 1 (5x7 glyph, 1 column and 3 rows
 * of spacing); a line is 10 * scale pixels high. */
static inline int overlay_text_width(const char *s, int scale) { return (int)strlen(s) * 6 * scale; }

static inline void overlay_text(unsigned char *img, int w, int h, int x0, int y0, int scale, const char *s,
                                const unsigned char rgb[3]) {
    for (int pass = 0; pass < 2; pass++) { /* black shadow, then the text */
        int ox = pass ? 0 : 1, oy = pass ? 0 : 1;
        static const unsigned char black[3] = {0, 0, 0};
        const unsigned char *c = pass ? rgb : black;
        int x = x0;
        for (const char *p = s; *p; p++, x += 6 * scale) {
            unsigned ch = (unsigned char)*p;
            if (ch < 32 || ch > 126) ch = '?';
            const unsigned char *g = k_font5x7[ch - 32];
            for (int col = 0; col < 5; col++)
                for (int row = 0; row < 8; row++) {
                    if (!(g[col] >> row & 1)) continue;
                    for (int sy = 0; sy < scale; sy++)
                        for (int sx = 0; sx < scale; sx++) {
                            int px = x + col * scale + sx + ox * scale, py = y0 + row * scale + sy + oy * scale;
                            if (px < 0 || py < 0 || px >= w || py >= h) continue;
                            memcpy(img + 3 * ((size_t)py * w + px), c, 3);
                        }
                }
        }
    }
}

/* Scales the pixels of [x0, x1) x [y0, y1) (clipped to the image) by `keep`. */
static inline void overlay_dim(unsigned char *img, int w, int h, int x0, int y0, int x1, int y1, float keep) {
    if (x0 < 0) x0 = 0;
    if (y0 < 0) y0 = 0;
    if (x1 > w) x1 = w;
    if (y1 > h) y1 = h;
    const int k = (int)(keep * 256.f + 0.5f);
    for (int y = y0; y < y1; y++)
        for (unsigned char *p = img + 3 * ((size_t)y * w + x0), *e = img + 3 * ((size_t)y * w + x1); p < e; p++)
            *p = (unsigned char)((*p * k) >> 8);
}

/* Draws n lines from (x, y), 10 * scale pixels apart, line i in colour rgb[i],
 * over one dimmed box reaching 3 * scale pixels beyond the text (shadows
 * included). The box is returned in box[4] (x0, y0, x1, y1, unclipped) when
 * box is not NULL. */
static inline void overlay_lines(unsigned char *img, int w, int h, int x, int y, int scale, const char *const *lines,
                                 int n, const unsigned char (*rgb)[3], int box[4]) {
    int tw = 0;
    for (int i = 0; i < n; i++) {
        int lw = overlay_text_width(lines[i], scale);
        if (lw > tw) tw = lw;
    }
    const int pad = 3 * scale;
    int b[4] = {x - pad, y - pad, x + tw + pad, y + 10 * scale * n + pad};
    if (n > 0) overlay_dim(img, w, h, b[0], b[1], b[2], b[3], OVERLAY_BOX_KEEP);
    for (int i = 0; i < n; i++) overlay_text(img, w, h, x, y + i * 10 * scale, scale, lines[i], rgb[i]);
    if (box) memcpy(box, b, sizeof b);
}

#endif
