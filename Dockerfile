# legplan batch image, two stages. The build stage installs what `make install` installs for
# building (the system packages of packaging/apt-packages.txt, the same pip commands) into a venv,
# without the test extras and without pip's cache; the runtime stage is the slim Python image with
# the runtime libraries of packaging/apt-packages-runtime.txt and that venv, run by a non-root user.
# tests/test_packaging.py checks that this file and the Makefile agree (no Docker engine there).
# Outputs on a bind mount belong to the caller with `docker run --user "$(id -u):$(id -g)"` (README).
FROM python:3.11-slim-bookworm AS build

WORKDIR /opt/legplan
COPY packaging/apt-packages.txt packaging/apt-packages.txt
RUN apt-get update -qq \
    && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(cat packaging/apt-packages.txt) \
    && rm -rf /var/lib/apt/lists/*
COPY . .
ENV PIP_NO_CACHE_DIR=1
RUN python -m venv /opt/venv \
    && /opt/venv/bin/python -m pip install -q --upgrade pip \
    && /opt/venv/bin/python -m pip install -q .

FROM python:3.11-slim-bookworm AS runtime

COPY packaging/apt-packages-runtime.txt /tmp/apt-packages-runtime.txt
RUN apt-get update -qq \
    && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $(cat /tmp/apt-packages-runtime.txt) \
    && rm -rf /var/lib/apt/lists/* /tmp/apt-packages-runtime.txt
COPY --from=build /opt/venv /opt/venv
RUN useradd --create-home --uid 1000 legplan
ENV PATH=/opt/venv/bin:$PATH MPLBACKEND=Agg MPLCONFIGDIR=/tmp/matplotlib
USER legplan
WORKDIR /data
ENTRYPOINT ["legplan"]
CMD ["--help"]
