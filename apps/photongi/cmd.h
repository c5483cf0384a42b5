/* Commands implemented outside main.c (one file each). Each returns the
 * process exit status: 0 success, 2 invalid arguments, 1 other failures. */
#ifndef PGI_CLI_CMD_H
#define PGI_CLI_CMD_H

int pgi_cmd_reference(int argc, char **argv);
int pgi_cmd_compare(int argc, char **argv);

#endif
