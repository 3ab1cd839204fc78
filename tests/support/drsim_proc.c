/* SPDX-License-Identifier: MIT */
/* Test support: run the real drsim binary as a child process. */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <libgen.h>
#include <limits.h>
#include <netinet/in.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "support/drsim_proc.h"

const char *drsim_path(void)
{
    static char path[PATH_MAX];
    char self[PATH_MAX];
    const char *env = getenv("DRSIM");
    if (env != NULL)
        return access(env, X_OK) == 0 ? env : NULL;
    ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n <= 0)
        return NULL;
    self[n] = '\0';
    /* $(B)/tests/unit/test_x -> $(B)/drsim */
    snprintf(path, sizeof path, "%s/../../drsim", dirname(self));
    return access(path, X_OK) == 0 ? path : NULL;
}

void drsim_ports(uint16_t *tcp, uint16_t *udp)
{
    static unsigned n;
    unsigned base = 20000u + ((unsigned)getpid() * 7u % 2000u) * 10u + (n++ % 5u) * 2u;
    *tcp = (uint16_t)base;
    *udp = (uint16_t)(base + 1u);
}

static void sleep_ms(long ms)
{
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

static bool accepts(const drsim_proc_t *p)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in sin;
    memset(&sin, 0, sizeof sin);
    sin.sin_family = AF_INET;
    sin.sin_port = htons(p->tcp_port);
    inet_pton(AF_INET, p->address, &sin.sin_addr);
    bool ok = fd >= 0 && connect(fd, (struct sockaddr *)&sin, sizeof sin) == 0;
    if (fd >= 0)
        close(fd);
    return ok;
}

bool drsim_start(drsim_proc_t *p, const char *const *extra)
{
    const char *path = drsim_path();
    if (path == NULL)
        return false;
    snprintf(p->address, sizeof p->address, "127.0.0.2");
    if (p->tcp_port == 0)
        drsim_ports(&p->tcp_port, &p->udp_port);
    char tcp[8], udp[8];
    snprintf(tcp, sizeof tcp, "%u", p->tcp_port);
    snprintf(udp, sizeof udp, "%u", p->udp_port);
    const char *argv[32] = {path, "--address", p->address, "--tcp-port", tcp, "--udp-port", udp};
    int argc = 7;
    for (int i = 0; extra != NULL && extra[i] != NULL && argc < 31; i++)
        argv[argc++] = extra[i];
    argv[argc] = NULL;
    p->pid = fork();
    if (p->pid < 0)
        return false;
    if (p->pid == 0) {
        /* drsim must not hold the test's output open (the runner reads it
         * to the end), and must not outlive a crashed test. */
        int devnull = open("/dev/null", O_WRONLY);
        const char *log = getenv("DRSIM_LOG");
        int out = log != NULL ? open(log, O_WRONLY | O_CREAT | O_APPEND, 0644) : devnull;
        if (out >= 0) {
            dup2(out, STDOUT_FILENO);
            dup2(out, STDERR_FILENO);
        }
        prctl(PR_SET_PDEATHSIG, SIGTERM);
        execv(path, (char *const *)argv);
        _exit(127);
    }
    for (int i = 0; i < 100; i++) {
        if (accepts(p))
            return true;
        int status;
        if (waitpid(p->pid, &status, WNOHANG) == p->pid) {
            p->pid = 0;
            return false;
        }
        sleep_ms(50);
    }
    drsim_stop(p);
    return false;
}

int drsim_stop(drsim_proc_t *p)
{
    int status = -1;
    if (p->pid <= 0)
        return -1;
    kill(p->pid, SIGTERM);
    for (int i = 0; i < 100; i++) {
        if (waitpid(p->pid, &status, WNOHANG) == p->pid) {
            p->pid = 0;
            return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        }
        sleep_ms(50);
    }
    kill(p->pid, SIGKILL);
    waitpid(p->pid, &status, 0);
    p->pid = 0;
    return -1;
}
