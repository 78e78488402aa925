// The live impact test's page (ema_pipeline.report.live_page): the state pushed over
// the WebSocket redrawn, the buttons and keys sent back as commands.
(function(){
var cfg=JSON.parse(document.getElementById('live-config').textContent);
var root=document.querySelector('[data-live]');
var WORDS=cfg.words,shown={},shownPoint='',last={};
var proto=location.protocol==='https:'?'wss://':'ws://';
var ws=null;
function q(s){return document.querySelector(s);}
function send(o){if(ws&&ws.readyState===1)ws.send(JSON.stringify(o));}
function set(id,html){if(last[id]===html)return false;
 last[id]=html;q(id).innerHTML=html;return true;}
function esc(s){return String(s).replace(/[&<>"]/g,function(c){
 return {'&':'&amp;','<':'&lt;','>':'&gt;','"':'&quot;'}[c];});}
function activate(el){[].slice.call(el.querySelectorAll('script')).forEach(function(old){
 if(old.type==='application/json')return;var s=document.createElement('script');
 s.textContent=old.textContent;old.parentNode.replaceChild(s,old);});}
function num(x,f,d){return x===null?'-':(f*x).toFixed(d);}
function render(st){
 root.setAttribute('data-streaming',st.streaming?'true':'false');
 root.setAttribute('data-finished',st.finished?'true':'false');
 root.setAttribute('data-final',st.final?'true':'false');
 root.setAttribute('data-identifying',st.identifying?'true':'false');
 if(st.current!==shownPoint){shown={};shownPoint=st.current;}
 set('#plan',st.points.map(function(p){return '<li data-point="'+p.number+'" data-node="'+
  p.node+'" data-state="'+p.state+'" data-accepted="'+p.accepted+'">'+esc(p.label)+
  '<br><small>'+p.accepted+' hits</small></li>';}).join(''));
 if(cfg.plan.nodes){var P=cfg.plan,svg='<svg class="plan" viewBox="0 0 240 150" '+
  'width="240" height="150">'+P.lines.map(function(l){return '<line x1="'+l[0]+'" y1="'+
  l[1]+'" x2="'+l[2]+'" y2="'+l[3]+'"/>';}).join('');
  st.points.forEach(function(p){var xy=P.nodes[String(p.node)];if(!xy)return;
   svg+='<circle data-plan-node="'+p.node+'" class="'+p.state+'" cx="'+xy[0]+'" cy="'+xy[1]+
    '" r="'+(p.state==='current'?7:5)+'"><title>'+esc(p.label)+'</title></circle>';});
  set('#plan-view',svg+'</svg>');}
 set('#channels',st.channels.map(function(c){return '<tr><td>'+esc(c[0])+'</td><td>'+
  esc(c[1])+'</td><td>'+esc(c[2])+'</td></tr>';}).join(''));
 q('#current').textContent=st.finished?'finished':(st.current?'point '+st.current:'');
 var now=Date.now();
 set('#hits',st.hits.map(function(h){if(!shown[h.number])shown[h.number]=now;
  var chips=h.reasons.map(function(r){return '<span class="chip reason">'+esc(WORDS[r]||r)+
   '</span>';}).join('');
  return '<li data-hit="'+h.number+'" data-status="'+h.status+'" data-reasons="'+
   esc(h.reasons.join(' '))+'" data-record-end-ms="'+h.record_end_ms+'" data-shown-ms="'+
   shown[h.number]+'">hit '+h.number+' at '+h.time_s.toFixed(3)+' s, '+
   h.peak_n.toFixed(1)+' N <span class="chip verdict">'+h.status+
   (h.by_hand?' (by hand)':'')+'</span>'+chips+'</li>';}).join('')||
  '<li class="muted">no hit yet</li>');
 set('#frf',st.frf_figure);set('#trace',st.trace_figure);
 var head=st.modes_error?'<p class="muted">'+esc(st.modes_error)+'</p>':
  (st.modes.length?'<p class="muted">'+(st.final?'final identification':'identified')+
   ' from '+st.modes_points+' point(s)</p>':'<p class="muted">'+
   (st.identifying?'identifying...':'no modes yet')+'</p>');
 set('#modes',head+(st.modes.length?'<table><tr><th>mode</th><th>fn / Hz</th>'+
  '<th>zeta / %</th></tr>'+st.modes.map(function(m){return '<tr data-live-mode="'+m.n+
  '" data-fn-hz="'+m.fn_hz+'" data-zeta="'+m.zeta+'"><td>'+m.n+'</td><td>'+
  num(m.fn_hz,1,2)+'</td><td>'+num(m.zeta,100,3)+'</td></tr>';}).join('')+
  '</table>':''));
 if(set('#shapes',st.shapes_html))activate(q('#shapes'));
 set('#messages',st.messages.map(function(m){return '<li>'+esc(m)+'</li>';}).join(''));
 q('[data-virtual-hit]').hidden=!st.virtual_hammer;
 root.setAttribute('data-version',st.version);}
function connect(){ws=new WebSocket(proto+location.host+cfg.ws);
 ws.onmessage=function(e){try{render(JSON.parse(e.data));}
  catch(err){q('#state').textContent='page error: '+err;}};
 ws.onclose=function(){q('#state').textContent='disconnected: retrying';
  setTimeout(connect,1000);};
 ws.onopen=function(){q('#state').textContent='connected';};}
q('[data-next-point]').onclick=function(){send({action:'next'});};
q('[data-finish]').onclick=function(){send({action:'finish'});};
q('[data-virtual-hit]').onclick=function(){send({action:'strike'});};
q('[data-accept]').onclick=function(){send({action:'accept'});};
q('[data-reject]').onclick=function(){send({action:'reject'});};
q('[data-undo]').onclick=function(){send({action:'undo'});};
document.addEventListener('keydown',function(e){if(e.target.tagName==='INPUT')return;
 var k=e.key.toLowerCase(),a={a:'accept',r:'reject',u:'undo',n:'next',h:'strike'}[k];
 if(a){send({action:a});e.preventDefault();}});
connect();
})();
