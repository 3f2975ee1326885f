# Sourced by vm_init.sh (busybox sh) after its stream check, with the board up and a LUT on it:
# `wdrctl stream --v4l2 /dev/video10` feeds a v4l2loopback device; `v4l2-ctl --stream-mmap`
# captures 3 frames from it, as any V4L2 program would; they must equal `wdrctl capture` of
# the board pixel for pixel (the virtual board's frames are all the same), in GREY and in Y16.
# Uses vm_init.sh's run, result, ctl and wait_for. Each check prints one @@RESULT line.
V4L2_DEV=/dev/video10

v4l2_load() {
    for ko in $(cat /lib/modules/v4l2/order); do
        case $ko in
        v4l2loopback.ko) insmod /lib/modules/v4l2/$ko video_nr=10 card_label=wdrcam ;;
        *) insmod /lib/modules/v4l2/$ko ;;
        esac || { echo "insmod $ko failed"; return 1; }
    done
    wait_for 10 test -c $V4L2_DEV
}

# The size and the pixel format the writer set: the size alone was already there from the grey
# check (trixie's v4l2loopback keeps the format after its writer closes), so the Y16 reader once
# started on GREY frames and one frame of three differed.
v4l2_format_set() { # W H FOURCC
    local f
    f=$(v4l2-ctl -d $V4L2_DEV --get-fmt-video 2>/dev/null)
    echo "$f" | grep -q "Width/Height *: *$1/$2" && echo "$f" | grep -q "Pixel Format *: *'$3"
}

v4l2_read() { # grey|y16, bytes of 3 frames: as any V4L2 program reads them (v4l2-ctl exits 0
    # even when STREAMON fails, so the file's size says whether the frames came)
    rm -f /tmp/v4l2.$1
    timeout 60 v4l2-ctl -d $V4L2_DEV --stream-mmap --stream-count=3 --stream-to=/tmp/v4l2.$1 >/tmp/v4l2-reader.log 2>&1 &&
        [ "$(wc -c </tmp/v4l2.$1)" -ge $2 ]
}

v4l2_check() { # grey|y16
    local fmt=$1 w h bpp=1 writer
    w=$(ctl info | sed -n 's/^geometry: *\([0-9]*\)x\([0-9]*\)/\1/p')
    h=$(ctl info | sed -n 's/^geometry: *\([0-9]*\)x\([0-9]*\)/\2/p')
    [ $fmt = y16 ] && bpp=2
    timeout 120 wdrctl stream --v4l2 $V4L2_DEV --format $fmt --timeout 3000 >/dev/null 2>/tmp/v4l2-writer.log &
    writer=$!
    local fourcc=GREY
    [ $fmt = y16 ] && fourcc="Y16 "
    wait_for 30 v4l2_format_set $w $h "$fourcc" || { cat /tmp/v4l2-writer.log; echo "the writer never set ${w}x$h"; kill $writer; return 1; }
    v4l2-ctl -d $V4L2_DEV --get-fmt-video
    # v4l2loopback 0.13 and later (trixie's 0.15) refuse STREAMON (EIO) until the writer has
    # sent its first frame; 0.12 (bookworm's) waits. So the reader asks again until then.
    wait_for 60 v4l2_read $fmt $((3 * w * h * bpp))
    local rc=$?
    cat /tmp/v4l2-reader.log
    kill $writer 2>/dev/null
    wait $writer 2>/dev/null
    cat /tmp/v4l2-writer.log
    [ $rc = 0 ] || { echo "v4l2-ctl --stream-mmap failed ($rc)"; return 1; }
    if [ $fmt = grey ]; then
        ctl capture -o /tmp/v4l2-capture.png --bits 8 --negate || return 1
    else
        ctl capture -o /tmp/v4l2-capture.png --raw || return 1
    fi
    v4l2_compare $fmt $w $h $((w * bpp)) /tmp/v4l2.$fmt 3 /tmp/v4l2-capture.png
}

if [ -f /v4l2/unavailable ]; then
    result v4l2_grey SKIP "$(cat /v4l2/unavailable)"
    result v4l2_y16 SKIP "$(cat /v4l2/unavailable)"
elif ! v4l2_load >/tmp/v4l2-load.log 2>&1; then
    result v4l2_grey FAIL "$(tail -1 /tmp/v4l2-load.log)"
    result v4l2_y16 FAIL "$(tail -1 /tmp/v4l2-load.log)"
else
    run v4l2_grey v4l2_check grey
    run v4l2_y16 v4l2_check y16
fi
