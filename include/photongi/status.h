/* photongi status codes and the last-error message (included by every header). */
#ifndef PHOTONGI_STATUS_H
#define PHOTONGI_STATUS_H

#ifdef __cplusplus
extern "C" {
#endif

typedef enum pgi_status {
    PGI_OK = 0,
    PGI_ERR_INVALID_ARG = 1, /* a parameter is out of range or unknown */
    PGI_ERR_IO = 2,          /* a file could not be read or written */
    PGI_ERR_PARSE = 3,       /* a file was read but its content is malformed */
    PGI_ERR_OOM = 4,         /* out of memory */
    PGI_ERR_UNSUPPORTED = 5, /* valid request this build cannot do */
    PGI_ERR_INTERNAL = 6,    /* a library (Embree, Assimp) failed */
    PGI_ERR_CANCELLED = 7    /* the caller asked the call to stop (pgi_cancel_request) */
} pgi_status;

/* Short name of a status code ("invalid argument"). Never NULL. */
const char *pgi_status_string(pgi_status s);
/* Detailed message of the last failing call on this thread ("" if none). */
const char *pgi_last_error(void);

#ifdef __cplusplus
}
#endif

#endif
