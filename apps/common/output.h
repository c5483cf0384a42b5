/* Output files checked before any work: a command that would render for
 * minutes and then fail to write its result says so at once. Header only
 * (static inline). */
#ifndef PGI_APPS_OUTPUT_H
#define PGI_APPS_OUTPUT_H

#include <errno.h>
#include <stdio.h>
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

#endif
