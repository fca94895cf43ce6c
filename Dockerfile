# legplan batch image. Installs exactly what `make install` installs: the system packages listed in
# packaging/apt-packages.txt, then the project with its test extras (tests/test_packaging.py checks
# that this file and the Makefile agree).
FROM python:3.11-slim-bookworm

WORKDIR /opt/legplan
COPY packaging/apt-packages.txt packaging/apt-packages.txt
RUN apt-get update -qq \
    && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(cat packaging/apt-packages.txt) \
    && rm -rf /var/lib/apt/lists/*
COPY . .
RUN python -m pip install -q --upgrade pip \
    && python -m pip install -q -e '.[test]'

WORKDIR /data
ENTRYPOINT ["legplan"]
CMD ["--help"]
