/* Output files checked before any work: a command that would render for
 * minutes and then fail to write its result says so at once. Header only
 * (static inline). */
#ifndef PGI__APPS_OUTPUT_H
#define PGI__APPS_OUTPUT_H

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

/* Checks that `path`, the value of option `opt` of command `prog` ("photongi render"), can be
 * written: its extension is one of `exts` (NULL-terminated, e.g. {".png", ".exr", NULL};
 * NULL: any name), its folder exists and is writable, and it is neither a folder nor a file
 * that cannot be written. Nothing is created or truncated here: an existing file stays as it
 * is until the command writes it at the end, so a command that fails on the way loses nothing.
 * (The folder may still change before then; the write reports that.) Returns 0, or prints
 * "<prog>: <opt> <path>: <problem>" and returns the exit status: 2 for an extension (a usage
 * error: the command line is wrong), 1 for the file system. */
static inline int app_check_output(const char *prog, const char *opt, const char *path, const char *const *exts) {
    if (!*path) {
        fprintf(stderr, "%s: %s needs a file name\nTry '%s --help'.\n", prog, opt, prog);
        return 2;
    }
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    if (exts) {
        const char *dot = strrchr(base, '.');
        int known = 0;
        for (int i = 0; exts[i] && dot; i++) known |= strcasecmp(dot, exts[i]) == 0;
        if (!known) {
            char list[64] = "";
            int count = 0;
            while (exts[count]) count++;
            for (int i = 0; i < count; i++) {
                size_t n = strlen(list);
                snprintf(list + n, sizeof list - n, "%s%s", i == 0 ? "" : i == count - 1 ? " or " : ", ", exts[i]);
            }
            if (dot) fprintf(stderr, "%s: %s %s: cannot write %s files; give a %s file\n", prog, opt, path, dot, list);
            else fprintf(stderr, "%s: %s %s: no file extension; give a %s file\n", prog, opt, path, list);
            fprintf(stderr, "Try '%s --help'.\n", prog);
            return 2;
        }
    }
    if (!*base) {
        fprintf(stderr, "%s: %s %s: is a folder, not a file\n", prog, opt, path);
        return 1;
    }
    char dir[4096];
    if (base == path) snprintf(dir, sizeof dir, ".");
    else if (base - path == 1) snprintf(dir, sizeof dir, "/");
    else snprintf(dir, sizeof dir, "%.*s", (int)(base - path - 1), path);
    struct stat st;
    if (stat(dir, &st) != 0) {
        if (errno == ENOENT) fprintf(stderr, "%s: %s %s: folder %s does not exist\n", prog, opt, path, dir);
        else fprintf(stderr, "%s: %s %s: cannot write there: folder %s: %s\n", prog, opt, path, dir, strerror(errno));
        return 1;
    }
    if (!S_ISDIR(st.st_mode)) {
        fprintf(stderr, "%s: %s %s: cannot write there: %s is not a folder\n", prog, opt, path, dir);
        return 1;
    }
    long name_max = pathconf(dir, _PC_NAME_MAX);
    if (name_max <= 0) name_max = 255;
    if ((long)strlen(base) > name_max) {
        fprintf(stderr, "%s: %s %.40s...: the name is %zu characters; folder %s allows at most %ld\n", prog, opt, base,
                strlen(base), dir, name_max);
        return 1;
    }
    if (strlen(path) >= 4096) {
        fprintf(stderr, "%s: %s %.40s...: the path is %zu characters; at most 4095\n", prog, opt, path, strlen(path));
        return 1;
    }
    if (access(dir, W_OK | X_OK) != 0) {
        fprintf(stderr, "%s: %s %s: cannot write in folder %s: %s\n", prog, opt, path, dir, strerror(errno));
        return 1;
    }
    if (stat(path, &st) == 0) {
        if (S_ISDIR(st.st_mode)) {
            fprintf(stderr, "%s: %s %s: is a folder, not a file\n", prog, opt, path);
            return 1;
        }
        if (access(path, W_OK) != 0) {
            fprintf(stderr, "%s: %s %s: cannot write the file: %s\n", prog, opt, path, strerror(errno));
            return 1;
        }
    }
    return 0;
}

/* realpath of the folder of `path`, and its name (app_canonical_output). */
static inline int app_canonical_output_dir(const char *path, char *out) {
    const char *base = strrchr(path, '/');
    char dir[4096];
    if (!base) snprintf(dir, sizeof dir, ".");
    else if (base == path) snprintf(dir, sizeof dir, "/");
    else snprintf(dir, sizeof dir, "%.*s", (int)(base - path), path);
    char *real = realpath(dir, NULL);
    if (!real) return 0;
    int n = snprintf(out, 4096, "%s/%s", strcmp(real, "/") == 0 ? "" : real, base ? base + 1 : path);
    free(real);
    return n > 0 && n < 4096;
}

/* The file `path` names, as a canonical path into out (cap 4096): realpath of the file when it
 * exists (a symlink's target), else realpath of its folder and its name. 0 when the folder cannot be
 * resolved (app_check_output reports that). */
static inline int app_canonical_output(const char *path, char *out) {
    char *real = realpath(path, NULL);
    if (real) {
        snprintf(out, 4096, "%s", real);
        free(real);
        return 1;
    }
    char link[4096], target[8192];
    ssize_t ln = readlink(path, link, sizeof link - 1);
    if (ln > 0) { /* a dangling symlink: the file it will create */
        link[ln] = 0;
        const char *slash = strrchr(path, '/');
        if (link[0] == '/' || !slash) snprintf(target, sizeof target, "%s", link);
        else snprintf(target, sizeof target, "%.*s/%s", (int)(slash - path), path, link);
        if (strcmp(target, path) != 0 && strlen(target) < 4096) {
            char copy[4096];
            snprintf(copy, sizeof copy, "%s", target);
            path = copy;
            real = realpath(path, NULL);
            if (real) {
                snprintf(out, 4096, "%s", real);
                free(real);
                return 1;
            }
            return app_canonical_output_dir(path, out);
        }
    }
    return app_canonical_output_dir(path, out);
}

/* Outputs that name the same file (the same path, a symlink to another, "a/../b" and "b") would
 * overwrite each other: a usage error, before anything is done. names[i] is the option of paths[i];
 * NULL paths and "-" (standard output) are skipped. Returns 0, or prints the pair and returns 2. */
static inline int app_check_distinct(const char *prog, int n, const char *const *names, const char *const *paths) {
    for (int i = 0; i < n; i++)
        for (int k = i + 1; k < n; k++) {
            if (!paths[i] || !paths[k] || strcmp(paths[i], "-") == 0 || strcmp(paths[k], "-") == 0) continue;
            char a[4096], b[4096];
            int same = strcmp(paths[i], paths[k]) == 0 ||
                       (app_canonical_output(paths[i], a) && app_canonical_output(paths[k], b) && strcmp(a, b) == 0);
            if (same) {
                fprintf(stderr, "%s: %s %s and %s %s name the same file; give each output its own\nTry '%s --help'.\n",
                        prog, names[i], paths[i], names[k], paths[k], prog);
                return 2;
            }
        }
    return 0;
}

#endif
