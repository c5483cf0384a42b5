/* Commands implemented outside main.c (one file each). Each returns the
 * process exit status (cli.h): 0 success, 2 usage error, 1 failure. */
#ifndef PGI_CLI_CMD_H
#define PGI_CLI_CMD_H

int pgi_cmd_reference(int argc, char **argv);
int pgi_cmd_compare(int argc, char **argv);

#endif
