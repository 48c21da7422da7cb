"""The pseudo-terminal under every fake device in tests/cli.

A fake (a CANable, a board's console, the ESP32-S3 ROM loader, a serial peer) is a pseudo-terminal pair: saulctl
opens the slave side by its path, as it would open /dev/ttyACM0, and the fake reads and writes the master side.
This module holds that plumbing once; the fakes hold only what the device says.

Three ways to drive a Pty, by what the test needs:
- read_until / read_some: a test script waits for a condition on the bytes saulctl wrote, with a bounded timeout
  (never a sleep), then answers with send.
- serve: a stand-alone fake (started by a shell test) announces its path on stdout and answers every chunk until
  its stdin says "quit" or closes.
- collect_in_background / drain: every byte saulctl wrote, read by a thread until the kernel says no slave is
  open any more, for tests that compare whole streams.
"""
import os
import select
import sys
import threading
import time
import tty


class Pty:
    """One pseudo-terminal pair; saulctl opens `path`, the fake uses `master`.

    The slave is put in raw mode at once because a new pty starts as a terminal: it echoes what the fake sends
    back to the fake, turns CR into NL, treats 0x03 as Ctrl-C and buffers input by line. A USB serial adapter
    does none of that, and the fakes speak binary protocols (SLIP, slcan, inter-board frames). saulctl makes the
    port raw itself when it opens it, but bytes that cross before then would be mangled, and a fake should not
    rely on the program under test to keep its wire clean. The settings belong to the pty, not to one fd.

    Our slave fd stays open for the fake's whole life. On Linux, reading the master gives EIO as soon as no slave
    fd is open; keeping one means a fake can wait for saulctl to open the path, and sees saulctl close it and
    open it again, without that error. drain() closes it on purpose to learn that saulctl has gone.
    """

    def __init__(self):
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        self.buf = b""  # everything read from the master so far
        self.arrivals = []  # (time.monotonic(), chunk) for each read, for timing checks
        self.link = None
        self._thread = None

    # --- a test script waiting for bytes -----------------------------------------------------------------------
    def read_some(self, timeout, size=4096):
        """Reads what has arrived within timeout seconds; b"" when nothing did (or the master is gone)."""
        r, _, _ = select.select([self.master], [], [], timeout)
        if not r:
            return b""
        try:
            chunk = os.read(self.master, size)
        except OSError:
            return b""
        self.arrivals.append((time.monotonic(), chunk))
        self.buf += chunk
        return chunk

    def read_until(self, predicate, timeout=5.0):
        """Reads until predicate(buffer) is true or timeout seconds have passed; returns the buffer (and keeps it)."""
        end = time.monotonic() + timeout
        while not predicate(self.buf):
            left = end - time.monotonic()
            if left <= 0 or not self.read_some(left):
                break
        return self.buf

    def send(self, data):
        os.write(self.master, data)

    # --- a stand-alone fake -------------------------------------------------------------------------------------
    def announce(self, link=None):
        """Prints the slave's path on stdout (the shell test reads that one line); link: also a symlink to it."""
        if link:
            if os.path.lexists(link):
                os.unlink(link)
            os.symlink(self.path, link)
            self.link = link
        print(self.path, flush=True)

    def serve(self, handle, size=65536):
        """Calls handle(chunk) for every chunk saulctl writes, until stdin says "quit" or closes.

        Waiting on stdin as well as the master lets the shell test end the fake at a moment of its choosing
        (then the fake writes its report) without signals or timeouts. An exception from handle ends the loop.
        """
        while True:
            ready, _, _ = select.select([self.master, sys.stdin], [], [])
            if sys.stdin in ready:
                line = sys.stdin.readline()
                if not line or line.strip() == "quit":
                    return
            if self.master not in ready:
                continue
            try:
                chunk = os.read(self.master, size)
            except OSError:
                continue  # nobody has the pty open right now
            handle(chunk)

    # --- a whole stream -----------------------------------------------------------------------------------------
    def collect_in_background(self, size=65536):
        """Starts a thread that reads the master into buf (and arrivals) until EIO or end of file."""
        def run():
            while True:
                try:
                    chunk = os.read(self.master, size)
                except OSError:  # EIO: no slave open any more and nothing left to read
                    return
                if not chunk:
                    return
                self.arrivals.append((time.monotonic(), chunk))
                self.buf += chunk

        self._thread = threading.Thread(target=run, daemon=True)
        self._thread.start()

    def drain(self):
        """Everything written to the slave, once saulctl has closed it: closes our slave fd, waits for the
        reader's EIO (Linux gives it only after the buffered bytes have been read), closes the master."""
        os.close(self.slave)
        self._thread.join(timeout=10)
        os.close(self.master)
        return self.buf

    # --- the end ------------------------------------------------------------------------------------------------
    def close_master(self):
        """The device vanishing: saulctl's next read or write on the slave fails."""
        os.close(self.master)

    def close(self):
        """Closes both sides (either may already be closed) and removes the announced symlink."""
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass
        if self.link and os.path.islink(self.link):
            os.unlink(self.link)
