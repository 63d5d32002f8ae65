/* vivid_ctl: presses one of the vivid driver's test buttons from inside the camera rig's guest
 * (tools/camrig), e.g. "Disconnect", which makes vivid act as an unplugged USB camera until every
 * open file handle is closed. Not a test by itself (tests/run.sh runs test_* only).
 *
 *   vivid_ctl /dev/video0 Disconnect [HOLD-SECONDS]
 *
 * With HOLD-SECONDS the device stays open that long after the press (a disconnected vivid comes
 * back only once every handle is closed: holding it keeps the camera "unplugged"). Exit 0 when the
 * control was found and set, 1 otherwise (one line on stderr). */
#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <stdio.h>
#include <string.h>
#include <stdlib.h>
#include <strings.h>
#include <sys/ioctl.h>
#include <unistd.h>

int main(int argc, char **argv)
{
    if (argc != 3 && argc != 4) {
        fprintf(stderr, "usage: vivid_ctl DEVICE CONTROL-NAME [HOLD-SECONDS]\n");
        return 2;
    }
    int fd = open(argv[1], O_RDWR | O_NONBLOCK);
    if (fd < 0) {
        fprintf(stderr, "vivid_ctl: %s: %s\n", argv[1], strerror(errno));
        return 1;
    }
    struct v4l2_queryctrl q;
    memset(&q, 0, sizeof q);
    q.id = V4L2_CTRL_FLAG_NEXT_CTRL;
    while (ioctl(fd, VIDIOC_QUERYCTRL, &q) == 0) {
        if (strcasecmp((const char *)q.name, argv[2]) == 0) {
            struct v4l2_control c = {.id = q.id, .value = q.type == V4L2_CTRL_TYPE_BUTTON ? 0 : 1};
            int r = ioctl(fd, VIDIOC_S_CTRL, &c);
            int err = errno;
            if (r == 0 && argc == 4) sleep((unsigned)atoi(argv[3]));
            close(fd);
            if (r < 0) {
                fprintf(stderr, "vivid_ctl: %s: setting '%s': %s\n", argv[1], argv[2],
                        strerror(err));
                return 1;
            }
            return 0;
        }
        q.id |= V4L2_CTRL_FLAG_NEXT_CTRL;
    }
    close(fd);
    fprintf(stderr, "vivid_ctl: %s: no control named '%s'\n", argv[1], argv[2]);
    return 1;
}
