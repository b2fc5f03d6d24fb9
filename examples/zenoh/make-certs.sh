#!/bin/sh
# Certificates for the two-host Zenoh example (tracker.json5, robot.json5; docs/integrations/zenoh.md, "Two hosts").
#
#     sh examples/zenoh/make-certs.sh DIR TRACKER_HOST
#
# makes, in DIR (created, private: umask 077), with openssl:
#   ca.pem, ca-key.pem            your own certificate authority (keep ca-key.pem off both hosts
#                                 once the certificates are made: whoever holds it can make a
#                                 certificate the two hosts will believe)
#   tracker.pem, tracker-key.pem  the tracking host's: common name wiithrow-tracker, and
#                                 TRACKER_HOST (a DNS name or an IP address: what robot.json5
#                                 connects to) as its subject alternative name, which the robot
#                                 host checks when it connects
#   robot.pem, robot-key.pem      the robot host's: common name wiithrow-robot
# The common names are what the access-control rules of the two files name: change them in
# both places or not at all. Copy ca.pem and tracker*.pem to the tracking host, ca.pem and
# robot*.pem to the robot host. EC P-256 keys, valid 825 days.
set -eu

dir=${1:?usage: make-certs.sh DIR TRACKER_HOST}
tracker_host=${2:?usage: make-certs.sh DIR TRACKER_HOST}
days=825

case "$tracker_host" in
*[!0-9.]*) case "$tracker_host" in *:*) san="IP:$tracker_host" ;; *) san="DNS:$tracker_host" ;; esac ;;
*) san="IP:$tracker_host" ;;
esac

umask 077
mkdir -p "$dir"
cd "$dir"

openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -days "$days" \
    -subj "/CN=wiithrow CA" -keyout ca-key.pem -out ca.pem \
    -addext "basicConstraints=critical,CA:TRUE" -addext "keyUsage=critical,keyCertSign,cRLSign" 2>/dev/null

# certificate NAME COMMON_NAME SUBJECT_ALT_NAME: a key and a certificate signed by the CA above.
certificate() {
    openssl req -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -subj "/CN=$2" \
        -keyout "$1-key.pem" -out "$1.csr" 2>/dev/null
    printf 'basicConstraints=critical,CA:FALSE\nkeyUsage=critical,digitalSignature\nextendedKeyUsage=serverAuth,clientAuth\nsubjectAltName=%s\n' \
        "$3" > "$1.ext"
    openssl x509 -req -in "$1.csr" -CA ca.pem -CAkey ca-key.pem -CAcreateserial -days "$days" \
        -extfile "$1.ext" -out "$1.pem" 2>/dev/null
    rm -f "$1.csr" "$1.ext"
}

certificate tracker wiithrow-tracker "$san"
certificate robot wiithrow-robot "DNS:wiithrow-robot"
rm -f ca.srl
echo "made $dir: ca.pem ca-key.pem tracker.pem tracker-key.pem ($san) robot.pem robot-key.pem"
